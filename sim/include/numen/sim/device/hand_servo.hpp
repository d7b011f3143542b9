#pragma once
/// @file hand_servo.hpp
/// A scripted hand that looks where it is going: a position-based visual servo of a point of a
/// body (docs/suturing.md, "The drivers' sight"). A scripted path plans the hand; a sighted
/// driver also plans where a point of what it holds should be (a needle's arc centre), sees it
/// in the simulation, and moves its hand by the difference. Each period, after the step, the
/// point's error against its planned target is observed; the hand's offset integrates that
/// error as the driver saw it `latency` earlier:
///
///   e(t)       = p*(t) − (x_b(t) + R_b(t) r)        (m, world; p* the target, r the body point)
///   o(t + dt)  = o(t) + (dt / T) e(t − L)            while a target is planned at t − L
///   |o| ≤ o_max                                      (clamped; the saturated periods counted)
///
/// and the hand's intent is the scripted pose moved by o (its orientation kept). With no target
/// planned, o is held. This is the integral law of position-based visual servoing (Chaumette &
/// Hutchinson, "Visual servo control, Part I: Basic approaches", IEEE Robotics & Automation
/// Magazine 13(4), 2006: the error in the task space, the camera's pose estimate standing in
/// for what the simulation gives exactly here), with a pure delay L for the eye and the hand.
/// A time constant T well above L keeps the loop stable (the phase L adds at the crossover
/// 1/T is L/T rad). With `predict`, the hand also knows what it did since it saw, as an
/// internal model of its own arm would (Miall, Weir, Wolpert & Stein, "Is the cerebellum a
/// Smith predictor?", J. Motor Behavior 25(3), 1993): it integrates e(t − L) − (o(t) − o(t − L)),
/// a Smith predictor for a hand that carries what it holds (Smith, "Closer control of loops with
/// dead time", Chem. Eng. Progress 53(5), 1957), so that T need not stay above L; what it
/// cannot know is the drift of the last L.
///
/// Frames and units: world (m), body frame (m), times (s). Construction allocates the delay
/// line; observe() is noexcept and allocation free.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "numen/core/types.hpp"

namespace numen::core {
struct Data;  // data.hpp: observe() reads its bodies
}

namespace numen::sim {

/// A servo's gains (`[device.trajectory.servo]`; docs/scenes.md).
struct HandServoSettings {
  double latency_s = 0.002;       ///< L (s, in [0, kMaxServoLatency]): the eye and hand's delay.
  double time_constant_s = 0.05;  ///< T (s, > 0): the integral's time constant.
  double max_offset_m = 0.004;    ///< o_max (m, > 0): the largest correction of the hand.
  /// A Smith predictor (see the file comment): the error seen L ago less the hand's own
  /// corrections since, e(t − L) − (o(t) − o(t − L)); false: e(t − L) as seen.
  bool predict = false;
};

/// The longest latency a servo takes (s): its delay line is latency / dt + 1 samples.
inline constexpr double kMaxServoLatency = 1.0;

/// The target over one scripted segment: the point `point` of body `body` from `target_start`
/// at `t0_s` to `target_end` at `t1_s`, linearly (trajectory time, s; world, m).
struct HandServoSpan {
  double t0_s = 0.0;
  double t1_s = 0.0;
  core::Vec3 target_start = core::Vec3::Zero();
  core::Vec3 target_end = core::Vec3::Zero();
  int body = -1;                          ///< The watched body (Model::bodies).
  core::Vec3 point = core::Vec3::Zero();  ///< The watched point in its frame (m).
};

/// What a device's servo watches and where it wants it.
struct HandServoSpec {
  HandServoSettings settings;
  std::string body_name;             ///< The watched bodies' names, ", " between (for messages).
  std::vector<HandServoSpan> spans;  ///< In time order, not overlapping.
};

/// Throws std::invalid_argument naming `who` and the setting for a latency outside
/// [0, kMaxServoLatency], a time constant or largest offset not finite and > 0, a span whose
/// times are not finite and increasing or that starts before the previous one ends, a
/// non-finite target or point, or a body index < 0.
void validate(const HandServoSpec& spec, const std::string& who);

/// One device's servo (see the file comment). Its offset starts at zero.
class HandServo {
 public:
  /// `dt_s` is the control period (s, > 0) at which observe() is called. Validates `spec`
  /// (throws std::invalid_argument as validate() does, and for dt not finite and > 0);
  /// allocates the delay line.
  HandServo(HandServoSpec spec, double dt_s, const std::string& who);

  /// After the period that ended at trajectory time `t_s` (s, non-decreasing from call to
  /// call): reads the span's watched point from `data` (Data::bodies; its body's index within it),
  /// takes the error L earlier from the delay line and integrates it. noexcept, no allocation.
  void observe(double t_s, const core::Data& data) noexcept;

  /// The hand's offset (m, world) for the next period.
  const core::Vec3& offset() const noexcept { return offset_; }
  /// The target at trajectory time `t_s` and whether one is planned there.
  bool target_at(double t_s, core::Vec3& target) const noexcept;

  /// The largest |offset| reached (m).
  double offset_max_m() const noexcept { return offset_max_m_; }
  /// The largest |error| observed while a target was planned (m).
  double error_max_m() const noexcept { return error_max_m_; }
  /// Periods whose offset was clamped to max_offset.
  std::int64_t saturated_periods() const noexcept { return saturated_; }
  /// The first trajectory time (s) the offset was clamped; −1 if never.
  double first_saturation_s() const noexcept { return first_saturation_s_; }
  const HandServoSpec& spec() const noexcept { return spec_; }
  /// The device whose hand it moves (`who` at construction), for messages.
  const std::string& device() const noexcept { return device_; }

 private:
  HandServoSpec spec_;
  std::string device_;
  double dt_s_;
  std::vector<core::Vec3> error_line_;  // the errors of the last n periods (ring)
  std::vector<char> planned_line_;      // whether a target was planned then
  std::vector<core::Vec3> offset_line_;  // the offset when each error was seen (predict)
  std::size_t head_ = 0;                // periods observed
  std::size_t span_ = 0;                // the first span not yet ended (a cursor: time grows)
  core::Vec3 offset_ = core::Vec3::Zero();
  double offset_max_m_ = 0.0;
  double error_max_m_ = 0.0;
  std::int64_t saturated_ = 0;
  double first_saturation_s_ = -1.0;
};

}  // namespace numen::sim
