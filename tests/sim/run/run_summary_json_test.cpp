// Tests of sim/run_summary_json: `numen run --json` holds every figure of the table at its
// path with the summary's value; the figures the text printed but the JSON lacked (issue 18)
// are there.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include <nlohmann/json.hpp>

#include "numen/sim/run/run_figures.hpp"
#include "numen/sim/run/run_summary.hpp"
#include "run_summary_samples.hpp"

namespace {

using nlohmann::json;

/// "a.b.c" as a JSON pointer "/a/b/c".
json::json_pointer pointer(std::string_view name) {
  std::string p(1, '/');
  p.append(name);
  for (char& c : p)
    if (c == '.') c = '/';
  return json::json_pointer(p);
}

TEST(RunSummaryJson, EveryFigureIsThereWithItsValue) {
  for (const numen::sim::RunSummary& s :
       {numen::test::full_managed_summary(), numen::test::admittance_summary()}) {
    const std::string text = numen::sim::format_summary_json(s);
    ASSERT_TRUE(json::accept(text)) << text;
    const json j = json::parse(text);
    for (const numen::sim::RunFigure& f : numen::sim::run_figures()) {
      if (f.present != nullptr && !f.present(s)) {
        EXPECT_FALSE(j.contains(pointer(f.name))) << f.name;
        continue;
      }
      ASSERT_TRUE(j.contains(pointer(f.name))) << f.name << " is not in " << text;
      const json& v = j.at(pointer(f.name));
      const numen::sim::FigureValue x = f.get(s);
      switch (x.kind) {
        case numen::sim::FigureKind::kReal: EXPECT_EQ(v.get<double>(), x.real) << f.name; break;
        case numen::sim::FigureKind::kCount:
          EXPECT_EQ(v.get<std::int64_t>(), x.count) << f.name;
          break;
        case numen::sim::FigureKind::kFlag: EXPECT_EQ(v.get<bool>(), x.flag) << f.name; break;
        case numen::sim::FigureKind::kText:
          EXPECT_EQ(v.get<std::string>(), x.text) << f.name;
          break;
        case numen::sim::FigureKind::kTextList:
          EXPECT_EQ(v.get<std::vector<std::string>>(), *x.list) << f.name;
          break;
      }
    }
  }
}

// Issue 18: the JSON lacked figures the text summary printed (the loop's period, budget and
// safe stops, the real-time factor, the exit status's name, k_hand × separation), besides the
// re-arm, overrun-limit, trocar and set-point figures.
TEST(RunSummaryJson, HoldsTheFiguresTheTextPrints) {
  const json j = json::parse(numen::sim::format_summary_json(numen::test::full_managed_summary()));
  EXPECT_EQ(j.at("rearm_requests"), 2);
  EXPECT_EQ(j.at("rearms_accepted"), 1);
  EXPECT_EQ(j.at("rearm_first_period"), 59);
  EXPECT_EQ(j.at("overrun_limit"), 4);
  EXPECT_EQ(j.at("trocar_note"), "trocar placed at the port");
  EXPECT_EQ(j.at("real_time_factor"), 2.0);
  EXPECT_EQ(j.at("exit_status_name"), "safety stop");
  EXPECT_EQ(j.at("loop").at("period_ns"), 1'000'000);
  EXPECT_EQ(j.at("loop").at("overrun_budget_ns"), 900'000);
  EXPECT_EQ(j.at("loop").at("invalid_periods"), 49);
  EXPECT_EQ(j.at("loop").at("safe_stops"), 1);
  EXPECT_EQ(j.at("loop").at("safe_stop"), true);
  EXPECT_FALSE(j.contains("admittance")) << "admittance figures only for admittance runs";
  const json a = json::parse(numen::sim::format_summary_json(numen::test::admittance_summary()));
  EXPECT_EQ(a.at("admittance").at("setpoints_clamped"), 68);
  EXPECT_EQ(a.at("admittance").at("setpoints_rate_limited"), 69);
  EXPECT_DOUBLE_EQ(a.at("admittance").at("final_hand_force_n").get<double>(), 200.0 * 24.75e-3);
}

TEST(RunSummaryJson, KeysKeepTheirOrderAndNonFiniteIsNull) {
  numen::sim::RunSummary s = numen::test::full_managed_summary();
  s.solver_residual_max = std::nan("");
  const std::string text = numen::sim::format_summary_json(s);
  EXPECT_EQ(text.substr(0, 10), "{\"scene\":\"");
  const json j = json::parse(text);
  EXPECT_TRUE(j.at("solver_residual_max").is_null());
  EXPECT_LT(text.find("\"steps\""), text.find("\"loop\""));
  EXPECT_LT(text.find("\"loop\""), text.find("\"exit_reasons\""));
}

}  // namespace

TEST(RunSummaryJson, SeveralDevicesHaveADevicesArrayOneDeviceNone) {
  const numen::sim::RunSummary two = numen::test::full_managed_summary();
  const nlohmann::json j = nlohmann::json::parse(numen::sim::format_summary_json(two));
  ASSERT_EQ(j.at("devices").size(), 2u);
  EXPECT_EQ(j.at("devices")[0].at("name"), "left");
  EXPECT_EQ(j.at("devices")[1].at("name"), "right");
  EXPECT_EQ(j.at("devices")[1].at("feedback_force_max_n"), 1.5);
  EXPECT_EQ(j.at("devices")[1].at("handle_force_max_n"), 2.25);  // closed loop: its hand's figures
  EXPECT_EQ(j.at("devices")[1].at("lifecycle"), "active");
  EXPECT_EQ(j.at("device_lines").size(), 2u);
  numen::sim::RunSummary one = two;
  one.devices.clear();
  one.device_lines.clear();
  const nlohmann::json j1 = nlohmann::json::parse(numen::sim::format_summary_json(one));
  EXPECT_FALSE(j1.contains("devices"));
  EXPECT_FALSE(j1.contains("device_lines"));
}
