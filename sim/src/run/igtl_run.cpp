/// @file igtl_run.cpp
/// The OpenIGTLink tracker of a run (igtl_run.hpp).

#include "numen/sim/run/igtl_run.hpp"

#include <cmath>

#include "numen/hal/features.hpp"
#include "numen/platform/latency_histogram.hpp"
#include "numen/sim/input/input_error.hpp"
#if NUMEN_WITH_OPENIGTLINK
#include "numen/hal/device/kinematics_factory.hpp"
#include "numen/hal/igtl/igtl_tracker_bus.hpp"
#endif

namespace numen::sim {

std::string igtl_run_refusal(const Scene& scene, const BusSpec& spec) {
  if (spec.kind != BusKind::kIgtl) return {};
  if (const std::string m = missing_backend(spec); !m.empty()) return m;
  if (!scene.igtl)
    return "the scene has no [device.igtl] (the OpenIGTLink tracker: device_name, host, port; "
           "docs/openigtlink.md)";
  if (scene.admittance) return "an admittance device cannot be an OpenIGTLink tracker";
  if (scene.device.canopen.managed)
    return "the tracker answers the minimal protocol's SYNC only: set [device.canopen] managed = false";
  return {};
}

#if NUMEN_WITH_OPENIGTLINK

namespace {

class IgtlRunImpl final : public IgtlRun {
 public:
  IgtlRunImpl(const Scene& scene, hal::IgtlTrackerSettings settings)
      : bus_(make_bus(scene, std::move(settings))) {}
  hal::Bus& bus() noexcept override { return bus_; }
  void set_time_ns(std::int64_t t_ns) noexcept override { bus_.set_time_ns(t_ns); }
  void finish() override { bus_.client().stop(); }
  void summarize(RunSummary& s) const override {
    const hal::IgtlClientCounters c = bus_.client().counters();
    const hal::IgtlBusCounters& b = bus_.tracker_counters();
    const hal::IgtlTrackerClientSettings& cs = bus_.client().settings();
    s.igtl = cs.host + ":" + std::to_string(cs.port) + " '" + cs.device_name + "'";
    s.igtl_messages = static_cast<std::int64_t>(c.messages);
    s.igtl_poses = static_cast<std::int64_t>(c.poses);
    s.igtl_poses_taken = static_cast<std::int64_t>(b.poses_taken);
    s.igtl_other_devices = static_cast<std::int64_t>(c.other_devices);
    s.igtl_ignored = static_cast<std::int64_t>(c.ignored);
    s.igtl_faults = static_cast<std::int64_t>(c.faults_total());
    s.igtl_dropped = static_cast<std::int64_t>(c.dropped_full);
    s.igtl_connects = static_cast<std::int64_t>(c.connects);
    s.igtl_connect_failures = static_cast<std::int64_t>(c.connect_failures);
    s.igtl_disconnects = static_cast<std::int64_t>(c.disconnects);
    s.igtl_wait_timeouts = static_cast<std::int64_t>(b.wait_timeouts);
    s.igtl_syncs_without_pose = static_cast<std::int64_t>(b.syncs_without_pose);
    s.igtl_stamps_backwards = static_cast<std::int64_t>(b.stamps_backwards);
    s.igtl_stamps_ahead = static_cast<std::int64_t>(b.stamps_ahead);
    s.igtl_stamps_unstamped = static_cast<std::int64_t>(b.stamps_unstamped);
    s.igtl_stamp_resyncs = static_cast<std::int64_t>(b.stamp_resyncs);
    s.igtl_silence_rebases = static_cast<std::int64_t>(b.silence_rebases);
    s.igtl_follows = bus_.settings().wait_for_tracker;
    s.igtl_periods_after_end = static_cast<std::int64_t>(b.syncs_after_end);
    s.igtl_fault_records.clear();
    for (const hal::IgtlFaultRecord& r : bus_.client().fault_records())
      s.igtl_fault_records.push_back(hal::describe(r) + " (" +
                                     std::to_string(c.faults[static_cast<std::size_t>(r.fault)]) +
                                     " such)");
    s.igtl_names_seen = bus_.client().names_seen();
    platform::LatencyHistogram h;
    for (std::int64_t ns : bus_.latency_ns()) h.record(ns);
    s.igtl_latency_us = summarize_ns(h);
  }

 private:
  // The bus; a registration TRANSFORM that never came is an error at the scene's key.
  static hal::IgtlTrackerBus make_bus(const Scene& scene, hal::IgtlTrackerSettings settings) {
    try {
      return hal::IgtlTrackerBus(scene.device, hal::make_kinematics(scene.device), std::move(settings));
    } catch (const hal::IgtlRegistrationMissing& e) {
      const IgtlTrackerScene& t = *scene.igtl;
      throw InputError(t.registration_file, t.registration_line, t.registration_column,
                       "device.igtl.registration", e.what());
    }
  }
  hal::IgtlTrackerBus bus_;
};

}  // namespace

std::unique_ptr<IgtlRun> make_igtl_run(const Scene& scene, const BusSpec& spec, bool paced) {
  if (spec.kind != BusKind::kIgtl) return nullptr;
  if (const std::string why = igtl_run_refusal(scene, spec); !why.empty())
    throw InputError("", 0, 0, "--bus", why);
  const IgtlTrackerScene& t = *scene.igtl;
  hal::IgtlTrackerSettings s;
  s.client.host = spec.igtl_host.empty() ? t.host : spec.igtl_host;
  s.client.port = spec.igtl_port != 0 ? spec.igtl_port : t.port;
  s.client.device_name = t.device_name;
  s.metres_per_unit = t.metres_per_unit;
  s.calibration = t.calibration;
  s.registration = t.registration;
  s.client.registration_name = t.registration_name;
  s.registration_wait_ns = std::llround(t.registration_wait_s * 1e9);
  s.wait_for_tracker = !paced;
  return std::make_unique<IgtlRunImpl>(scene, std::move(s));
}

#else

std::unique_ptr<IgtlRun> make_igtl_run(const Scene& scene, const BusSpec& spec, bool paced) {
  (void)paced;
  if (spec.kind != BusKind::kIgtl) return nullptr;
  throw InputError("", 0, 0, "--bus", igtl_run_refusal(scene, spec));
}

#endif

}  // namespace numen::sim
