// Tests of sim/cli_values: the `numen` command's time options refuse what would silently pick a
// default (nan) or print DBL_MAX in full (-1 against CLI11's NonNegativeNumber), with a short
// message quoting the value as typed.
#include "numen/sim/input/cli_values.hpp"

#include <gtest/gtest.h>

#include <string>

#include "numen/sim/scene/scene.hpp"

namespace {

using numen::sim::check_seconds;
using numen::sim::kMaxRunDuration;

TEST(CliValues, DurationMustBeAFinitePositiveNumberOfSeconds) {
  for (const char* good : {"5", "0.001", "1e3", "10000000", "+2.5"}) {
    EXPECT_EQ(check_seconds(good, 0.0, kMaxRunDuration, true), "") << good;
  }
  for (const char* bad : {"nan", "NaN", "-nan", "inf", "-1", "0", "-0", "1e400", "2e7", "", "abc",
                          "5s", " 5", "0x"}) {
    SCOPED_TRACE(bad);
    const std::string m = check_seconds(bad, 0.0, kMaxRunDuration, true);
    EXPECT_NE(m, "");
    EXPECT_NE(m.find("must be a finite number of seconds in (0, 1e+07]"), std::string::npos) << m;
    EXPECT_NE(m.find(std::string("got '") + bad + "'"), std::string::npos) << m;
    EXPECT_LT(m.size(), 100u) << "no DBL_MAX in full: " << m;
  }
}

TEST(CliValues, PhaseMayBeZero) {
  EXPECT_EQ(check_seconds("0", 0.0, 1.0, false), "");
  EXPECT_EQ(check_seconds("0.0005", 0.0, 1.0, false), "");
  EXPECT_NE(check_seconds("-1", 0.0, 1.0, false).find("in [0, 1], got '-1'"), std::string::npos);
  EXPECT_NE(check_seconds("nan", 0.0, 1.0, false), "");
}

TEST(CliValues, AControlByteInTheValueIsShown) {
  const std::string m = check_seconds(std::string("5\x1b[2J", 5), 0.0, 10.0, true);
  EXPECT_NE(m.find("got '5\\x1B[2J'"), std::string::npos) << m;
}

}  // namespace
