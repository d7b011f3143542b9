/// @file study_passivity_probe.cpp
/// The probe of `numen study passivity` (study_passivity.hpp; docs/passivity.md "Probe"): one
/// device axis (AxisPlant), an encoder, a controller at period T rendering a direct wall or a
/// 1-DOF god-object behind a virtual coupling (optionally through hal::PassivityController),
/// and four hand motions; the energy the hand puts into the device port decides passivity.

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include "numen/hal/device/foaw_estimator.hpp"
#include "numen/hal/device/passivity_controller.hpp"
#include "numen/hal/device/rate_estimator.hpp"
#include "numen/sim/device/axis_plant.hpp"
#include "numen/sim/study/study_passivity.hpp"

namespace numen::sim {
namespace {

/// The encoder: the position rounded to the nearest count (hal/src/device/axis.cpp), or the
/// position itself for Δ = 0.
double encoder_reading(double x, double resolution) {
  return resolution > 0.0 ? resolution * std::round(x / resolution) : x;
}

/// The controller: reads the encoder at the start of each period, estimates the velocity by
/// PassivityPoint::velocity_estimator (the backward difference by default) and returns the
/// force to hold over the period. The wall's surface
/// (and the god-object's obstacle) is x = 0, the wall occupies x > 0. With
/// PassivityPoint::passivity_controller the force goes through hal::PassivityController (the
/// device's own class, one axis, the backward difference as its rate, the default velocity
/// threshold, PassivityPoint::passivity_energy_limit_j), as ImpedanceDevice::write() does
/// before its clamp.
class ProbeController {
 public:
  ProbeController(const PassivityPoint& p, double x0)
      : p_(p),
        god_object_(p.coupling == "god-object"),
        estimator_(p.velocity_estimator == "filter" ? kFilter
                   : p.velocity_estimator == "foaw" ? kFoaw
                                                    : kDifference),
        previous_(encoder_reading(x0, p.resolution)),
        go_x_(previous_),
        filter_(kPassivityFilterCutoffHz, std::numeric_limits<double>::infinity(), false),
        foaw_(hal::kFoawMaxWindow, 0.5 * p.resolution, std::numeric_limits<double>::infinity(),
              false),
        passivity_(1, p.period_s, p.passivity_controller ? 1u : 0u,
                   hal::kDefaultPassivityVelocityThreshold, p.passivity_energy_limit_j) {
    // The estimators start from the reading at rest (v̂ = 0 until the next one).
    filter_.update(previous_, 0);
    foaw_.update(previous_, 0);
  }

  double force(double x) {
    const double xq = encoder_reading(x, p_.resolution);
    const double difference = (xq - previous_) / p_.period_s;
    previous_ = xq;
    ++k_;
    const std::int64_t t_ns = std::llround(static_cast<double>(k_) * p_.period_s * 1e9);
    double v = difference;
    if (estimator_ == kFilter) v = filter_.update(xq, t_ns);
    if (estimator_ == kFoaw) v = foaw_.update(xq, t_ns);
    double f[1] = {render(xq, v)};
    const double rate[1] = {difference};
    if (p_.passivity_controller) (void)passivity_.apply(f, rate);
    return f[0];
  }

 private:
  /// The environment's force at the encoder reading xq and the rate estimate v.
  double render(double xq, double v) {
    if (!god_object_) return xq > 0.0 ? -p_.stiffness * xq - p_.damping * v : 0.0;
    // The god-object (mass m_g, position g, velocity u) coupled to the device by the spring-
    // damper (K, B) (paper Eq. 2, target = the device) and held out of the obstacle x > 0 by
    // the penalty k_w·g (paper §5), one linearly implicit Euler step of T (paper Eq. 1):
    //   m_g (u' − u) = T [K (x̂ − g') + B (v̂ − u') − k_w max(g', 0)],  g' = g + T u'.
    // The obstacle term is piecewise linear in u': the free case is tried first, then the one
    // in contact (exactly one is consistent: the right-hand side decreases with u').
    const double t = p_.period_s, m = kPassivityGodObjectMass, k = p_.stiffness, b = p_.damping;
    const double rhs = m * go_u_ + t * (k * (xq - go_x_) + b * v);
    double u = rhs / (m + t * t * k + t * b);
    if (go_x_ + t * u > 0.0) {
      const double kw = p_.obstacle_stiffness;
      u = (rhs - t * kw * go_x_) / (m + t * t * (k + kw) + t * b);
    }
    go_u_ = u;
    go_x_ += t * u;
    // The device feels the coupling's reaction (paper Eq. 8 with the coupling's gains).
    return k * (go_x_ - xq) + b * (go_u_ - v);
  }

  enum Estimator { kDifference, kFilter, kFoaw };

  PassivityPoint p_;
  bool god_object_;
  Estimator estimator_;
  double previous_;    ///< The last encoder reading (m).
  std::int64_t k_ = 0;  ///< Periods read so far.
  double go_x_ = 0.0;  ///< God-object position (m).
  double go_u_ = 0.0;  ///< God-object velocity (m/s).
  hal::RateEstimator filter_;
  hal::FoawEstimator foaw_;
  hal::PassivityController passivity_;
};

/// The hand: a mass m_h, damper c_h and spring k_h (held over a sub-step) pulling the device
/// towards the intent X(t): F = k_h (X − x) + c_h (Ẋ − v) − m_h a.
struct ProbeHand {
  double mass = 0.0;
  double damping = 0.0;
  double stiffness = 0.0;
};

/// The energy record of one run: E(t) = ∫ F_hand v dt sampled at every sub-step (a run whose E
/// is not finite stops there with energy_min = −∞), and the device position at the end of every
/// period.
struct ProbeTrace {
  double energy_min = 0.0;
  double energy_peak = 0.0;
  std::vector<double> x;  ///< Position at the end of each period (m).
};

constexpr int kProbeSubsteps = 2;
constexpr double kFar = std::numeric_limits<double>::infinity();

/// Runs `periods` control periods from rest at `x0` with the hand `hand` following `intent`.
template <class Intent>
ProbeTrace run_probe(const PassivityPoint& p, double x0, const ProbeHand& hand, int periods,
                     Intent&& intent, bool keep_positions) {
  AxisPlantSettings s;
  s.inertia = kPassivityDeviceMass;
  s.damping = p.device_damping;
  s.coulomb = p.coulomb;
  s.delay_periods = p.delay_periods;
  AxisPlant plant(s);
  plant.reset(x0, 0.0);
  ProbeController controller(p, x0);
  ProbeTrace trace;
  if (keep_positions) trace.x.reserve(static_cast<std::size_t>(periods));
  const double t = p.period_s, h = t / kProbeSubsteps;
  // The share of the plant's damping energy that is the hand's damper.
  const double hand_share =
      hand.damping > 0.0 ? hand.damping / (hand.damping + p.device_damping) : 0.0;
  double energy = 0.0, external = 0.0, damping = 0.0;
  for (int k = 0; k < periods; ++k) {
    plant.command(controller.force(plant.q()));
    for (int j = 0; j < kProbeSubsteps; ++j) {
      const double t0 = k * t + j * h;
      const double x_start = intent(t0), x_end = intent(t0 + h);
      const double f =
          hand.stiffness * (x_start - plant.q()) + hand.damping * (x_end - x_start) / h;
      const double v0 = plant.qdot();
      plant.step(h, f, hand.mass, hand.damping);
      // F_hand = f − c_h v − m_h a: the port's work is the plant's `external` work less the
      // hand damper's share of the damping energy less the hand mass's kinetic energy.
      const AxisPlantEnergy& e = plant.energy();
      const double v1 = plant.qdot();
      energy += (e.external - external) - hand_share * (e.damping - damping) -
                0.5 * hand.mass * (v1 * v1 - v0 * v0);
      external = e.external;
      damping = e.damping;
      if (!std::isfinite(energy)) {  // the run blew up: not passive, said as −∞
        trace.energy_min = -kFar;
        return trace;
      }
      trace.energy_min = std::min(trace.energy_min, energy);
      trace.energy_peak = std::max(trace.energy_peak, std::abs(energy));
    }
    if (keep_positions) trace.x.push_back(plant.q());
  }
  return trace;
}

/// A raised-cosine move from a to b over [t0, t0 + d]: a before, b after.
double raised_cosine_move(double t, double t0, double d, double a, double b) {
  if (t <= t0) return a;
  if (t >= t0 + d) return b;
  return a + (b - a) * 0.5 * (1.0 - std::cos(std::numbers::pi * (t - t0) / d));
}

/// The stiff hand of the press, dither and resonance runs: a damper c_h = 1000 m / T (the
/// device follows the intent's velocity within T/1000) with a spring k_h = c_h / (5 T) removing
/// the drift.
ProbeHand stiff_hand(const PassivityPoint& p) {
  ProbeHand hand;
  hand.damping = 1000.0 * kPassivityDeviceMass / p.period_s;
  hand.stiffness = hand.damping / (5.0 * p.period_s);
  return hand;
}

/// One oscillation window of the contact run: amplitude (half peak-to-peak, m) and frequency
/// (Hz) when it is sustained (docs/passivity.md "Limit cycles"), else zeros.
struct ProbeOscillation {
  double amplitude = 0.0;
  double hz = 0.0;
};

ProbeOscillation sustained_oscillation(const std::vector<double>& x, std::size_t begin,
                                       std::size_t end, double period) {
  ProbeOscillation o;
  if (end <= begin + 4 || end > x.size()) return o;
  const auto span = [&](std::size_t a, std::size_t b) {
    const auto [lo, hi] = std::minmax_element(x.begin() + static_cast<std::ptrdiff_t>(a),
                                              x.begin() + static_cast<std::ptrdiff_t>(b));
    return 0.5 * (*hi - *lo);
  };
  const std::size_t mid = (begin + end) / 2;
  const double a1 = span(begin, mid), a2 = span(mid, end), a = span(begin, end);
  double mean = 0.0;
  for (std::size_t i = begin; i < end; ++i) mean += x[i];
  mean /= static_cast<double>(end - begin);
  int crossings = 0;
  for (std::size_t i = begin + 1; i < end; ++i)
    if ((x[i - 1] - mean) * (x[i] - mean) < 0.0) ++crossings;
  if (a >= 1e-8 && crossings >= 2 && a2 >= 0.8 * a1) {
    o.amplitude = a;
    o.hz = crossings / (2.0 * static_cast<double>(end - begin) * period);
  }
  return o;
}

void check_point(const PassivityPoint& p) {
  const auto bad = [](const std::string& what) {
    throw std::invalid_argument("passivity probe: " + what);
  };
  if (!(std::isfinite(p.period_s) && p.period_s > 0.0)) bad("period_s must be finite and > 0");
  if (!(std::isfinite(p.stiffness) && p.stiffness >= 0.0)) bad("stiffness must be finite and >= 0");
  if (!std::isfinite(p.damping)) bad("damping must be finite");
  if (!(std::isfinite(p.resolution) && p.resolution >= 0.0))
    bad("resolution must be finite and >= 0");
  if (!(p.passivity_energy_limit_j > 0.0))
    bad("passivity_energy_limit_j must be > 0 (+inf: none)");
  if (p.velocity_estimator != "difference" && p.velocity_estimator != "filter" &&
      p.velocity_estimator != "foaw")
    bad("velocity_estimator must be \"difference\", \"filter\" or \"foaw\" (got \"" +
        p.velocity_estimator + "\")");
  if (p.coupling != "wall" && p.coupling != "god-object")
    bad("coupling must be \"wall\" or \"god-object\" (got \"" + p.coupling + "\")");
  if (p.coupling == "god-object" &&
      !(std::isfinite(p.obstacle_stiffness) && p.obstacle_stiffness >= 0.0))
    bad("obstacle_stiffness must be finite and >= 0");
}

}  // namespace

PassivityProbe probe_passivity(const PassivityPoint& p) {
  check_point(p);  // AxisPlant checks b, f_c and the delay.
  const double t = p.period_s, delta = p.resolution;
  PassivityProbe out;
  double worst = std::numeric_limits<double>::infinity();
  const auto account = [&](const ProbeTrace& r, const char* name) {
    const double eps = kPassivityEpsilonRelative * r.energy_peak + 1e-18;
    if (r.energy_min < -eps) out.passive = false;
    const double score = r.energy_min / eps;
    if (score < worst) {
      worst = score;
      out.worst_run = name;
    }
    out.energy_min_j = std::min(out.energy_min_j, r.energy_min);
    out.energy_peak_j = std::max(out.energy_peak_j, r.energy_peak);
  };
  const ProbeHand stiff = stiff_hand(p);

  // Press: from rest on the wall's surface to a depth of 200 counts (2 mm for Δ = 0) and back,
  // raised-cosine moves of 400 periods each: slow against T, many counts deep, at most 0.8
  // count per period (Colgate; Abbott & Okamura's bound assumes motion at the count scale). It
  // starts and ends at rest with nothing stored, so E at the end is the net work.
  {
    const double x0 = 0.0, depth = delta > 0.0 ? 200.0 * delta : 2e-3;
    const double d = 400.0 * t;
    const auto intent = [=](double s) {
      return s < d + 50.0 * t ? raised_cosine_move(s, 0.0, d, x0, depth)
                              : raised_cosine_move(s, d + 50.0 * t, d, depth, x0);
    };
    account(run_probe(p, x0, stiff, 900, intent, false), "press");
  }
  // Dither: a stroke of 2a in one period, then d periods at rest, back and forth, 100 times
  // (d = the delay in periods), from rest at zero stored energy, then 2 periods at rest (the
  // device's kinetic energy, large against one cycle's net work, is then 0). With Δ > 0 it crosses
  // the first count boundary Δ/2 (a = Δ/100): the force is one count low on the way in and one
  // count high on the way out (Abbott & Okamura's worst case); with Δ = 0 it runs from the
  // surface to 2a = 20 µm at the Nyquist rate (where B > 0 binds, Colgate & Schenkel).
  {
    const double a = delta > 0.0 ? delta / 100.0 : 1e-5;
    const double low = delta > 0.0 ? delta / 2.0 - a : 0.0, high = low + 2.0 * a;
    const int cycle = 2 * (p.delay_periods + 1);
    const auto intent = [=](double s) {
      const double periods = s / t;
      const double in_cycle = std::fmod(periods, static_cast<double>(cycle));
      const double half = cycle / 2.0;
      if (periods >= 100.0 * cycle) return low;  // at rest again: E is the net work
      if (in_cycle < 1.0) return low + (high - low) * in_cycle;
      if (in_cycle < half) return high;
      if (in_cycle < half + 1.0) return high - (high - low) * (in_cycle - half);
      return low;
    };
    account(run_probe(p, low, stiff, 100 * cycle + 2, intent, false), "dither");
  }
  // Resonance: the stiff hand moves the device through the samples X_k = A (1 − cos θ* k),
  // linearly between them (constant velocity over each period: the sampled motion at θ* that
  // dissipates least), θ* the frequency at which the delay bound binds, for at least 20 cycles
  // and 400 periods, then back to the surface in 200 periods (raised cosine) and at rest.
  // Colgate & Schenkel's worst frequency is θ → 0 (the press) for B <= 0 without delay and π
  // (the dither) for B > 0 without delay; with a delay and B > 0 it lies between.
  const double theta = delay_bound_frequency(p);
  if (std::isfinite(theta) && theta > 0.01 && theta < std::numbers::pi - 0.01) {
    const double amp = delta > 0.0 ? 100.0 * delta : 1e-3;
    const int cycles =
        std::max(20, static_cast<int>(std::ceil(400.0 * theta / (2.0 * std::numbers::pi))));
    const int periods = static_cast<int>(std::ceil(cycles * 2.0 * std::numbers::pi / theta));
    const auto sample = [=](int k) { return amp * (1.0 - std::cos(theta * k)); };
    const auto intent = [=](double s) {
      const double u = s / t;
      if (u >= periods) return raised_cosine_move(s, periods * t, 200.0 * t, sample(periods), 0.0);
      const int k = static_cast<int>(std::floor(u));
      return sample(k) + (sample(k + 1) - sample(k)) * (u - k);
    };
    account(run_probe(p, 0.0, stiff, periods + 202, intent, false), "resonance");
  }
  // Contact: a hand (0.2 kg, 10 N·s/m, 300 N/m) whose intent goes from 1 mm outside to 5 mm
  // inside the wall in 0.1 s, holds 0.4 s, returns in 0.1 s and rests 0.4 s: the limit-cycle
  // probe. Its energy is reported apart (contact_passive): it moves many counts per period,
  // outside the other runs' design (docs/passivity.md).
  {
    ProbeHand hand;
    hand.mass = 0.2;
    hand.damping = 10.0;
    hand.stiffness = 300.0;
    const double x0 = -1e-3, depth = 5e-3;
    const auto intent = [=](double s) {
      return s < 0.5 ? raised_cosine_move(s, 0.0, 0.1, x0, depth)
                     : raised_cosine_move(s, 0.5, 0.1, depth, x0);
    };
    const int periods = static_cast<int>(std::lround(1.0 / t));
    const ProbeTrace r = run_probe(p, x0, hand, periods, intent, true);
    out.contact_energy_min_j = r.energy_min;
    out.contact_passive = r.energy_min >= -(kPassivityEpsilonRelative * r.energy_peak + 1e-18);
    // Windows: the last 0.2 s of the hold and the last 0.2 s of the rest after the release.
    const auto at = [&](double s) { return static_cast<std::size_t>(std::lround(s / t)); };
    for (const ProbeOscillation& o : {sustained_oscillation(r.x, at(0.3), at(0.5), t),
                                      sustained_oscillation(r.x, at(0.8), at(1.0), t)}) {
      if (o.amplitude > out.limit_cycle_amplitude_m) {
        out.limit_cycle = true;
        out.limit_cycle_amplitude_m = o.amplitude;
        out.limit_cycle_hz = o.hz;
      }
    }
    // A run whose device left ±1 m (or whose position or energy is not finite) diverged: a
    // growing oscillation counts as one, its amplitude the largest |x| reached (∞ if not
    // finite).
    double reach = 0.0;
    for (double x : r.x) reach = std::isfinite(x) ? std::max(reach, std::abs(x)) : kFar;
    if (!std::isfinite(r.energy_min)) reach = kFar;
    if (reach > 1.0) {
      out.limit_cycle = true;
      out.limit_cycle_amplitude_m = std::max(out.limit_cycle_amplitude_m, reach);
    }
  }
  return out;
}

}  // namespace numen::sim
