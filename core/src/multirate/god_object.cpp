/// @file god_object.cpp
/// The two loops of a multirate god-object interleaved on one thread (MultirateGodObject,
/// numen/core/multirate/god_object.hpp, docs/multirate.md): construction, the device loop's
/// period and its report, tool switching, the single-rate view. The scene loop's period is
/// scene_loop.cpp's.

#include "numen/core/multirate/god_object.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "numen/core/data.hpp"
#include "numen/core/features.hpp"
#include "numen/core/grasp.hpp"
#include "numen/core/model.hpp"
#include "numen/core/needle.hpp"
#include "numen/core/rigid_body.hpp"
#include "numen/core/sliding_tie.hpp"
#include "numen/core/step.hpp"

#include "scratch/data_scratch.hpp"
#include "multirate/contact.hpp"
#include "multirate/net.hpp"
#include "numen/core/multirate/device_loop.hpp"

namespace numen::core {
namespace {

using detail::copy_counts;
using detail::god_object_contact;

// The sub-steps of a folded scene step of `h` s (MultirateSettings::fold_step): 1 unless the
// step is longer than fold_step.
int fold_substeps(double h, double fold_step) noexcept {
  if constexpr (!kWithDeformable) return 1;
  return h > fold_step ? static_cast<int>(std::min(std::ceil(h / fold_step), 1000.0)) : 1;
}

// The model of one sub-step of a folded scene step: `scene_loop` (finalized) with dt = its dt
// / `substeps`, finalized with its god-object's bodies `god` one articulation
// (detail::finalize_scene_loop_model()). Built once, at construction: no Model is written at
// run time.
Model fold_model_of(const Model& scene_loop, int substeps, std::span<const int> god) {
  if (substeps <= 1) return Model{};
  Model m = scene_loop;
  m.dt = scene_loop.dt / substeps;
  if (std::string error = detail::finalize_scene_loop_model(m, god); !error.empty())
    throw std::invalid_argument("multirate: folded scene-loop model: " + error);
  return m;
}

// Both jaws of grasper `g` are in the god-object (`device_body`: per scene body its god-object
// model index or −1): it grasps in the device step (make_god_object_model()).
bool grasped_in(const GraspModel& g, const std::vector<int>& device_body) noexcept {
  for (int jaw : g.jaws)
    if (jaw < 0 || jaw >= static_cast<int>(device_body.size()) ||
        device_body[static_cast<std::size_t>(jaw)] < 0)
      return false;
  return true;
}

// The refusals of carried bodies and graspers (MultirateGodObject's constructor): throws
// std::invalid_argument naming the body or grasper. `riders`: the other devices' bodies and the
// carried ones; `slots`: the bodies the device may hold.
void check_carried(const Model& scene, int body, const MultirateSettings& settings,
                   std::span<const int> riders, std::size_t slots) {
  const std::vector<int>& tree = scene.articulation.body_tree;
  const auto tree_of = [&](int b) {
    return tree.size() == scene.bodies.size() ? tree[static_cast<std::size_t>(b)] : b;
  };
  std::vector<int> instruments(settings.other_devices);
  if (body >= 0) instruments.push_back(body);
  for (int t : settings.tools) instruments.push_back(t);
  for (int c : settings.carried) {
    if (c < 0 || c >= scene.num_bodies())
      throw std::invalid_argument("multirate: carried body " + std::to_string(c) +
                                  " is not a body of the scene (" +
                                  std::to_string(scene.num_bodies()) + " bodies)");
    const BodyModel& bm = scene.bodies[static_cast<std::size_t>(c)];
    const auto refuse = [&](const std::string& why) {
      throw std::invalid_argument("multirate: carried body '" + bm.name + "' " + why +
                                  ": the device loop carries free bodies only");
    };
    if (bm.anchored) refuse("is anchored");
    for (const JointModel& j : scene.joints)
      if (j.child == c || j.parent == c) refuse("is in joint '" + j.name + "'");
    for (const NetModel& n : scene.nets)
      if (n.body == c) refuse("is the component of net '" + n.name + "'");
    for (int i : instruments)
      if (i >= 0 && i < scene.num_bodies() && tree_of(i) == tree_of(c))
        refuse("is in an instrument's articulation");
  }
  if (scene.grasps.empty()) return;
  if (slots > 1)
    throw std::invalid_argument(
        "multirate: graspers hold what they hold in the device step, and a switch of the held "
        "body would drop it: a scene with [[grasp]] runs multirate with one held body (no "
        "attach events to another)");
  if (body < 0 && settings.tools.empty()) return;
  const int held = body >= 0 ? body : settings.tools.front();
  std::vector<int> device_body(scene.bodies.size(), -1);
  for (int g : god_object_bodies(scene, held, riders)) device_body[static_cast<std::size_t>(g)] = 0;
  for (const GraspModel& g : scene.grasps)
    if (!grasped_in(g, device_body))
      throw std::invalid_argument("multirate: grasper '" + g.name +
                                  "' has a jaw in no device's instrument: the device loop "
                                  "grasps, and the scene loop does not");
}

}  // namespace

MultirateGodObject::MultirateGodObject(const Model& scene, int body,
                                       const MultirateSettings& settings)
    : ratio_(settings.ratio),
      margin_(settings.margin),
      fold_substeps_(fold_substeps(scene.dt * settings.ratio, settings.fold_step)),
      body_(body) {
  if (settings.ratio < 1)
    throw std::invalid_argument("multirate: the rate ratio scene_dt / dt must be >= 1 (got " +
                                std::to_string(settings.ratio) + ")");
  if (!(settings.fold_step > 0.0))
    throw std::invalid_argument("multirate: fold_step must be > 0 s (got " +
                                std::to_string(settings.fold_step) + ")");
  if (!(settings.margin >= 0.0) || !std::isfinite(settings.margin))
    throw std::invalid_argument("multirate: the contact margin must be >= 0 m and finite (got " +
                                std::to_string(settings.margin) + ")");
  if (!settings.other_devices.empty() && body < 0)
    throw std::invalid_argument("multirate: with other devices the first device must hold a body "
                                "from the start: their instruments ride in its god-object");
  other_devices_ = !settings.other_devices.empty();
  std::vector<int> bodies;
  if (body >= 0) bodies.push_back(body);
  for (int t : settings.tools)
    if (std::find(bodies.begin(), bodies.end(), t) == bodies.end()) bodies.push_back(t);
  if (bodies.empty())
    throw std::invalid_argument("multirate: no god-object: the device holds no body and has no tools");
  // The carried bodies ride in every god-object as the other devices' instruments do.
  std::vector<int> riders = settings.other_devices;
  riders.insert(riders.end(), settings.carried.begin(), settings.carried.end());
  check_carried(scene, body, settings, riders, bodies.size());
  std::size_t largest = 1;
  for (int b : bodies) {
    Slot s;
    s.body = b;
    const std::span<const int> others(riders);
    std::string error = make_god_object_model(scene, b, scene.dt, s.device_model, others);
    if (error.empty()) error = make_proximity_model(scene, b, settings.margin, s.scene_model, others);
    if (!error.empty()) throw std::invalid_argument(error);
    s.bodies = god_object_bodies(scene, b, others);
    s.device_body.assign(scene.bodies.size(), -1);
    for (std::size_t i = 0; i < s.bodies.size(); ++i)
      s.device_body[static_cast<std::size_t>(s.bodies[i])] = static_cast<int>(i);
    for (std::size_t j = 0; j < scene.joints.size(); ++j)
      if (s.device_body[static_cast<std::size_t>(scene.joints[j].child)] >= 0)
        s.joints.push_back(static_cast<int>(j));
    largest = std::max(largest, s.bodies.size());
    s.scene_model.dt = scene.dt * settings.ratio;
    // The god-object moves in the scene loop as the device loop moved it: imposed (kDirect, an
    // infinitely heavy body for the scene's implicit solve: the held body by the target, the
    // rest of its articulation by their body targets), its joints left to the device loop.
    s.scene_model.coupling_mode = CouplingMode::kDirect;
    s.scene_model.initial_held_body = b;
    std::vector<JointModel> kept;
    for (std::size_t j = 0; j < s.scene_model.joints.size(); ++j)
      if (s.device_body[static_cast<std::size_t>(s.scene_model.joints[j].child)] < 0) {
        kept.push_back(s.scene_model.joints[j]);
        s.scene_joints.push_back(static_cast<int>(j));
      }
    s.scene_model.joints = std::move(kept);
    // A needle the device loop steps: its tip's contacts are the device loop's, and so is the
    // puncture test (test_punctures(), make_requested_punctures()).
    for (NeedleModel& n : s.scene_model.needles)
      n.puncture_on_request = s.device_body[static_cast<std::size_t>(n.body)] >= 0;
    error = detail::finalize_scene_loop_model(s.scene_model, s.bodies);
    if (!error.empty()) throw std::invalid_argument("multirate: scene-loop model: " + error);
    s.fold_model = fold_model_of(s.scene_model, fold_substeps_, s.bodies);
    for (std::size_t g = 0; g < scene.grasps.size(); ++g)
      if (grasped_in(scene.grasps[g], s.device_body)) s.grasps.push_back(static_cast<int>(g));
    s.device = make_god_object_data(s.device_model);
    s.scene = make_data(s.scene_model);
    slots_.push_back(std::move(s));
  }
  for (const NetModel& net : scene.nets) {
    bool held = false;
    for (const Slot& s : slots_)
      held = held || std::find(s.bodies.begin(), s.bodies.end(), net.body) != s.bodies.end();
    // An organ (a net on an anchored body) stays in the scene loop; its contacts with the
    // god-object reach the device loop as planes on the god-object's spheres (build_node_planes).
    if (!held && !scene.bodies[static_cast<std::size_t>(net.body)].anchored)
      throw std::invalid_argument("multirate: net '" + net.name +
                                  "' is on a body in no god-object the device may hold: the "
                                  "device loop would not feel it");
  }
  free_scene_model_ = scene;
  free_scene_model_.dt = scene.dt * settings.ratio;
  free_scene_model_.initial_held_body = -1;
  free_scene_model_.grasps.clear();  // the device step's (make_god_object_model())
  if (std::string error = finalize_model(free_scene_model_); !error.empty())
    throw std::invalid_argument("multirate: scene-loop model: " + error);
  free_fold_model_ = fold_model_of(free_scene_model_, fold_substeps_, {});
  free_scene_ = make_data(free_scene_model_);
  for (std::size_t j = 0; j < scene.joints.size(); ++j) free_joints_.push_back(static_cast<int>(j));
  scene_slot_ = slot_ = body >= 0 ? 0 : -1;
  scene_ = body >= 0 ? &slots_[0].scene : &free_scene_;
  scene_->held_body = body;
  for (Slot& s : slots_)
    for (std::size_t i = 0; i < s.bodies.size(); ++i)
      s.device.bodies[i] = scene_->bodies[static_cast<std::size_t>(s.bodies[i])];
  const std::size_t nb = scene.bodies.size();
  impulse_total_.assign(nb, Wrench{});
  owed_.assign(nb, Wrench{});
  seen_total_.assign(nb, Wrench{});
  base_applied_.assign(nb, Wrench{});
  released_states_.assign(largest, BodyState{});
  snapshot_ = make_step_outputs(*scene_, scene.joints.size());
  if (scene.num_nets() > 0) {
    node_slot_.assign(static_cast<std::size_t>(scene.num_nodes()), -1);
    slot_node_.assign(kMaxContactPlanes, -1);
    node_stiffness_.assign(kMaxContactPlanes, Mat3::Zero());
    plane_slot_.assign(kMaxContactPlanes, -1);
    planes_stiffness_.assign(kMaxContactPlanes, 0.0);
    planes_depth_.assign(kMaxContactPlanes, 0.0);
    node_force_.assign(kMaxContactPlanes, Vec3::Zero());
    plane_springs_.assign(scene.node_springs.size(), 0);
  }
  puncture_requests_.assign(scene.needles.size(), 0.0);
  tip_forces_.assign(scene.needles.size(), 0.0);
  report_ = make_report();
  scene_report_ = make_scene_report();
}

MultirateDeviceReport MultirateGodObject::make_report() const {
  MultirateDeviceReport r;
  r.impulse_total.assign(impulse_total_.size(), Wrench{});
  r.states.assign(released_states_.size(), BodyState{});
  r.released_states.assign(released_states_.size(), BodyState{});
  r.puncture_requests.assign(puncture_requests_.size(), 0.0);
  write_report(r);
  return r;
}

MultirateSceneReport MultirateGodObject::make_scene_report() const {
  MultirateSceneReport m;
  m.scene = snapshot_;
  return m;
}

int MultirateGodObject::slot_of(int body) const noexcept {
  for (std::size_t i = 0; i < slots_.size(); ++i)
    if (slots_[i].body == body) return static_cast<int>(i);
  return -1;
}

Wrench MultirateGodObject::owed_impulse(int b) const noexcept {
  Wrench w;
  if (b < 0 || b >= static_cast<int>(owed_.size())) return w;
  const auto i = static_cast<std::size_t>(b);
  w.force = owed_[i].force + impulse_total_[i].force - seen_total_[i].force;
  w.torque = owed_[i].torque + impulse_total_[i].torque - seen_total_[i].torque;
  return w;
}

std::span<const int> MultirateGodObject::god_object() const noexcept {
  if (slot_ < 0) return {};
  return std::span<const int>(slot().bodies);
}

void MultirateGodObject::take_targets(const Data& scene_data) noexcept {
  if (slot_ < 0) return;
  Slot& s = slot();
  Data& d = s.device;
  d.target = scene_data.target;
  d.target_twist = scene_data.target_twist;
  d.device_wrench = scene_data.device_wrench;  // CouplingMode::kAdmittance (Data::device_wrench)
  for (std::size_t i = 0; i < s.bodies.size(); ++i) {
    const auto b = static_cast<std::size_t>(s.bodies[i]);
    if (b < scene_data.body_targets.size()) d.body_targets[i] = scene_data.body_targets[b];
    // Each body's Eq. 8 gains and saturation are its device's (several devices).
    if (b < scene_data.feedback_group.size()) d.feedback_group[i] = scene_data.feedback_group[b];
  }
  for (std::size_t g = 0; g < d.feedback_point.size() && g < scene_data.feedback_point.size(); ++g)
    d.feedback_point[g] = scene_data.feedback_point[g];  // each device's saturation point
  for (std::size_t j = 0; j < s.joints.size(); ++j) {
    const auto sj = static_cast<std::size_t>(s.joints[j]);
    if (sj < scene_data.joint_prescribed.size()) d.joint_prescribed[j] = scene_data.joint_prescribed[sj];
  }
}

bool MultirateGodObject::select(int body) noexcept {
  if (body == body_) return true;
  if (body < 0 && other_devices_) return false;  // the other devices' instruments ride in it
  const int next = body >= 0 ? slot_of(body) : -1;
  if (body >= 0 && next < 0) return false;
  released_body_ = body_;
  if (slot_ >= 0) {
    const Slot& old = slot();
    for (std::size_t i = 0; i < old.bodies.size() && i < released_states_.size(); ++i)
      released_states_[i] = old.device.bodies[i];
  }
  slot_ = next;
  body_ = body;
  if (slot_ >= 0) {
    Slot& s = slot();
    for (std::size_t i = 0; i < s.bodies.size(); ++i)
      s.device.bodies[i] = snapshot_.bodies[static_cast<std::size_t>(s.bodies[i])];
    s.device.num_contacts = 0;
  }
  planes_.count = 0;
  planes_.carrier_count = 0;
  planes_.link_count = 0;
  planes_.tie_count = 0;
  period_ = 0;  // one thread: a scene period now, the new god-object's planes
  ++switches_;
  ++counters_.switches;
  return true;
}

void MultirateGodObject::write_report(MultirateDeviceReport& out) const noexcept {
  out.period = counters_.device_steps;
  out.body = body_;
  if (slot_ >= 0) {
    const Slot& s = slot();
    for (std::size_t i = 0; i < s.bodies.size() && i < out.states.size(); ++i) out.states[i] = s.device.bodies[i];
  }
  const std::size_t n = std::min(out.impulse_total.size(), impulse_total_.size());
  for (std::size_t b = 0; b < n; ++b) out.impulse_total[b] = impulse_total_[b];
  out.switches = switches_;
  out.released_body = released_body_;
  for (std::size_t i = 0; i < out.released_states.size() && i < released_states_.size(); ++i)
    out.released_states[i] = released_states_[i];
  std::copy_n(puncture_requests_.begin(), std::min(puncture_requests_.size(), out.puncture_requests.size()),
              out.puncture_requests.begin());
}

bool MultirateGodObject::take_scene_report(const MultirateSceneReport& m) noexcept {
  copy_outputs(m.scene, snapshot_);
  if (m.body != body_) return false;  // sampled before a switch: not this god-object's planes
  planes_.count = std::clamp(m.planes.count, 0, kMaxContactPlanes);
  planes_.carrier_count = std::clamp(m.planes.carrier_count, 0, kMaxPlaneCarriers);
  planes_.dropped = m.planes.dropped;
  std::copy_n(m.planes.planes.begin(), planes_.count, planes_.planes.begin());
  std::copy_n(m.planes.carriers.begin(), planes_.carrier_count, planes_.carriers.begin());
  planes_.link_count = std::clamp(m.planes.link_count, 0, kMaxCarrierLinks);
  std::copy_n(m.planes.links.begin(), planes_.link_count, planes_.links.begin());
  planes_.tie_count = std::clamp(m.planes.tie_count, 0, kMaxPunctureTies);
  std::copy_n(m.planes.ties.begin(), planes_.tie_count, planes_.ties.begin());
  planes_.pull_count = std::clamp(m.planes.pull_count, 0, kMaxThreadPulls);
  std::copy_n(m.planes.pulls.begin(), planes_.pull_count, planes_.pulls.begin());
  periods_since_model_ = 0;
  apply_thread_pulls();
  return true;
}

void MultirateGodObject::apply_thread_pulls() noexcept {
  if (slot_ < 0 || free_scene_model_.threads.empty()) return;  // a run without a thread: nothing
  Data& d = slot().device;
  for (Wrench& w : d.applied_wrench) w = Wrench{};
  for (int i = 0; i < planes_.pull_count; ++i) {
    const ThreadPull& p = planes_.pulls[static_cast<std::size_t>(i)];
    if (p.body < 0 || p.body >= static_cast<int>(d.applied_wrench.size())) continue;
    d.applied_wrench[static_cast<std::size_t>(p.body)].force += p.wrench.force;
    d.applied_wrench[static_cast<std::size_t>(p.body)].torque += p.wrench.torque;
  }
}

void MultirateGodObject::hand_back() noexcept {
  const int np = std::clamp(planes_.count, 0, kMaxContactPlanes);
  for (int i = 0; i < np; ++i) {
    const ContactPlane& p = planes_.planes[static_cast<std::size_t>(i)];
    if (p.other_body < 0 || p.other_body >= static_cast<int>(impulse_total_.size()) ||
        p.carrier < 0 || p.carrier >= planes_.carrier_count ||
        planes_.carriers[static_cast<std::size_t>(p.carrier)].node >= 0)  // the scene step's own
      continue;
    // About the body's centre of mass as the device loop moved it.
    const PlaneCarrier& k = planes_.carriers[static_cast<std::size_t>(p.carrier)];
    Wrench& w = impulse_total_[static_cast<std::size_t>(p.other_body)];
    w.force -= p.impulse;
    w.torque -= (p.impulse_point - (k.com + k.displacement)).cross(p.impulse);
  }
}

void MultirateGodObject::device_step(const MultirateSceneReport* fresh) noexcept {
  took_model_ = fresh != nullptr;
  if (fresh != nullptr) {
    // What the new planes add at the god-object's pose (MultirateCounters::reset_energy).
    const bool held = slot_ >= 0;
    const double before = held ? plane_elastic_energy(device_model(), planes_, slot().device) : 0.0;
    if (take_scene_report(*fresh) && held) {
      const double added = plane_elastic_energy(device_model(), planes_, slot().device) - before;
      if (added > 0.0) {
        counters_.reset_energy += added;
        counters_.reset_energy_max = std::max(counters_.reset_energy_max, added);
      }
    }
  }
  if (slot_ >= 0) {
    if (periods_since_model_ >= ratio_) ++counters_.stale_models;
    hold_on_puncture_ties();
    step_god_object(device_model(), planes_, slot().device);
    carry_puncture_ties();
    hand_back();
    test_punctures();
  }
  ++periods_since_model_;
  ++counters_.device_steps;
  ++period_;
}

void MultirateGodObject::hold_on_puncture_ties() noexcept {
  Data& d = slot().device;
  d.num_sliding_ties = 0;
  const int nt = std::clamp(planes_.tie_count, 0, kMaxPunctureTies);
  for (int i = 0; i < nt; ++i) {
    PunctureTie& p = planes_.ties[static_cast<std::size_t>(i)];
    p.force.setZero();
    tie_slots_[static_cast<std::size_t>(i)] = -1;
    if (p.needle < 0 || p.needle >= free_scene_model_.num_needles() || p.body < 0 ||
        p.body >= static_cast<int>(d.bodies.size()) || d.num_sliding_ties >= kMaxSlidingTies)
      continue;
    const NeedleModel& n = free_scene_model_.needles[static_cast<std::size_t>(p.needle)];
    const BodyState& b = d.bodies[static_cast<std::size_t>(p.body)];
    const Vec3 local = b.orientation.conjugate() * (p.anchor - b.position);
    const double s = needle_closest_parameter(n, local);
    // Off the arc (tie_needles() lets it go): nothing until the next sample drops it.
    if (needle_point_behind_tail(n, local, s) || needle_point_past_tip(n, local, s)) continue;
    tie_slots_[static_cast<std::size_t>(i)] = d.num_sliding_ties;
    SlidingTie& t = d.sliding_ties[static_cast<std::size_t>(d.num_sliding_ties++)];
    t.body = p.body;
    t.local_point = needle_point(n, s);
    t.anchor = p.anchor;
    t.anchor_velocity = p.velocity;
    t.axis = b.orientation * needle_tangent(n, s);
    t.stiffness = n.tie_stiffness;
    t.damping = n.tie_damping;
    t.friction = n.friction;
  }
}

void MultirateGodObject::carry_puncture_ties() noexcept {
  const Data& d = slot().device;
  const double h = device_model().dt;
  const int nt = std::clamp(planes_.tie_count, 0, kMaxPunctureTies);
  for (int i = 0; i < nt; ++i) {
    PunctureTie& p = planes_.ties[static_cast<std::size_t>(i)];
    const int k = tie_slots_[static_cast<std::size_t>(i)];
    if (k >= 0 && k < d.num_sliding_ties) p.force = d.sliding_ties[static_cast<std::size_t>(k)].force;
    p.anchor += h * p.velocity;
  }
}

void MultirateGodObject::test_punctures() noexcept {
  if constexpr (!kWithDeformable) return;
  const Model& scene = free_scene_model_;  // the scene's needles, with their scene bodies
  for (std::size_t k = 0; k < scene.needles.size() && k < puncture_requests_.size(); ++k) {
    const NeedleModel& n = scene.needles[k];
    double& request = puncture_requests_[k];
    tip_forces_[k] = 0.0;
    const int local = slot_ >= 0 ? slot().device_body[static_cast<std::size_t>(n.body)] : -1;
    if (local < 0 || k >= snapshot_.needles.size() || snapshot_.needles[k].num_punctures > 0) {
      request = 0.0;  // not the device loop's, or made: the scene loop's passage now
      continue;
    }
    const Data& d = slot().device;
    const BodyState& b = d.bodies[static_cast<std::size_t>(local)];
    const Vec3 t = b.orientation * needle_tangent(n, n.length());
    const double cos_max = std::cos(n.puncture_max_angle);
    Vec3 force = Vec3::Zero();  // on the needle
    bool facing = false;
    const int nc = std::clamp(d.num_contacts, 0, kMaxContacts);
    for (int i = 0; i < nc; ++i) {
      const Contact& c = d.contacts[static_cast<std::size_t>(i)];
      if (c.body_b >= 0 || c.body_a != local || c.sphere_b < 0 || c.sphere_b >= planes_.count) continue;
      const ContactPlane& p = planes_.planes[static_cast<std::size_t>(c.sphere_b)];
      if (p.node < 0 || p.sphere < n.sphere_count - 3) continue;  // tissue on the tip's spheres
      force += c.force;
      facing = facing || (-c.normal).dot(t) >= cos_max;
    }
    tip_forces_[k] = -force.dot(t);
    if (request > 0.0) {  // latched until made, unless the tip eased off
      if (tip_forces_[k] < n.puncture_force) request = 0.0;
    } else if (tip_forces_[k] >= n.puncture_force && facing) {
      request = tip_forces_[k];
    }
  }
}

void MultirateGodObject::step() noexcept {
  const bool sample = period_ % ratio_ == 0;
  if (sample) {
    write_report(report_);
    scene_step(report_, scene_report_);
  }
  device_step(sample ? &scene_report_ : nullptr);
}

void MultirateGodObject::write_feedback(Data& out) const noexcept {
  if (slot_ < 0) return;
  const Slot& s = slot();
  const Data& d = s.device;
  for (std::size_t i = 0; i < s.bodies.size(); ++i) {
    const auto g = static_cast<std::size_t>(s.bodies[i]);
    if (g < out.bodies.size()) out.bodies[g] = d.bodies[i];
    if (g < out.body_feedback.size()) out.body_feedback[g] = d.body_feedback[i];
  }
  out.coupling_wrench = d.coupling_wrench;
  out.device_wrench = d.device_wrench;
  out.feedback_wrench = d.feedback_wrench;
}

void MultirateGodObject::view(Data& out) const noexcept {
  const StepOutputs& snap = snapshot_;
  const std::size_t nb = std::min(out.bodies.size(), snap.bodies.size());
  for (std::size_t b = 0; b < nb; ++b) {
    out.bodies[b] = snap.bodies[b];
    if (b < out.body_feedback.size()) out.body_feedback[b] = Wrench{};
  }
  const std::size_t nj = std::min(out.joints.size(), snap.joints.size());
  for (std::size_t j = 0; j < nj; ++j) out.joints[j] = snap.joints[j];
  out.max_joint_drift = snap.max_joint_drift;
  out.max_joint_angle_drift = snap.max_joint_angle_drift;
  // The scene loop's contacts not on the god-object (those on it are the device loop's).
  int count = 0;
  double deepest = 0.0;
  const std::span<const int> device_body =
      slot_ >= 0 ? std::span<const int>(slot().device_body) : std::span<const int>();
  for (int i = 0; i < snap.num_contacts; ++i) {
    const Contact& c = snap.contacts[static_cast<std::size_t>(i)];
    bool on_a = false;
    if (god_object_contact(c, device_body, on_a)) continue;  // sampled before a switch
    out.contacts[static_cast<std::size_t>(count++)] = c;
    deepest = std::max(deepest, c.depth);
  }
  // The nets, the god-object's included, and the needles' passages, as the scene loop left them.
  detail::copy_nets(snap, out);
  std::copy_n(snap.needles.begin(), std::min(snap.needles.size(), out.needles.size()), out.needles.begin());
  for (std::size_t k = 0; k < out.needles.size() && k < tip_forces_.size(); ++k)  // the rendered one
    if (slot_ >= 0 && k < free_scene_model_.needles.size() &&
        slot().device_body[static_cast<std::size_t>(free_scene_model_.needles[k].body)] >= 0)
      out.needles[k].tip_force = tip_forces_[k];
  // The threads as the scene loop left them; their step's events (a break, a Newton iteration
  // that ran out) in the one view after that step.
  for (std::size_t i = 0; i < out.threads.size() && i < snap.threads.size(); ++i) {
    copy_thread_state(snap.threads[i], out.threads[i]);
    if (!took_model_) {
      out.threads[i].output.broke = false;
      out.threads[i].output.converged = true;
    }
  }
  for (int i = 0; i < out.num_node_contacts; ++i)
    deepest = std::max(deepest, out.node_contacts[static_cast<std::size_t>(i)].depth);
  for (const NetOutput& o : out.nets)
    deepest = std::max(deepest, o.crossed_depth);  // dropped, not hidden
  out.contacts_dropped = took_model_ ? snap.contacts_dropped : 0;
  out.contacts_clamped = took_model_ ? snap.contacts_clamped : 0;
  copy_counts(snap, out);
  out.status = took_model_ ? snap.status : kStepOk;
  out.stages_run = took_model_ ? snap.stages_run : 0u;
  out.solver_iterations = took_model_ ? snap.solver_iterations : 0;
  out.solver_residual = took_model_ ? snap.solver_residual : 0.0;
  out.coupling_wrench = Wrench{};
  out.device_wrench = Wrench{};
  out.feedback_wrench = Wrench{};
  out.invalid_target_steps = 0;  // only the device loop's steps take the device targets
  for (const Slot& s : slots_) {
    out.contact_overflow_steps += s.device.contact_overflow_steps;
    out.contact_clamped_steps += s.device.contact_clamped_steps;
    out.nonfinite_steps += s.device.nonfinite_steps;
    out.invalid_target_steps += s.device.invalid_target_steps;
  }
  if (slot_ >= 0) {
    const Slot& s = slot();
    const Data& d = s.device;
    write_feedback(out);
    for (std::size_t j = 0; j < s.joints.size(); ++j) {
      const auto sj = static_cast<std::size_t>(s.joints[j]);
      if (sj < out.joints.size()) out.joints[sj] = d.joints[j];
    }
    out.max_joint_drift = std::max(out.max_joint_drift, d.max_joint_drift);
    out.max_joint_angle_drift = std::max(out.max_joint_angle_drift, d.max_joint_angle_drift);
    const int nd = std::clamp(d.num_contacts, 0, kMaxContacts);
    for (int i = 0; i < nd; ++i) {
      if (count >= kMaxContacts) {
        ++out.contacts_dropped;
        continue;
      }
      Contact c = d.contacts[static_cast<std::size_t>(i)];
      // A god-object body's sphere index and body in the scene.
      const auto to_scene = [&](int& body, int& sphere) noexcept {
        const int local = std::clamp(body, 0, static_cast<int>(s.bodies.size()) - 1);
        const int g = s.bodies[static_cast<std::size_t>(local)];
        sphere = s.scene_model.bodies[static_cast<std::size_t>(g)].sphere_begin +
                 (sphere - s.device_model.bodies[static_cast<std::size_t>(local)].sphere_begin);
        body = g;
      };
      if (c.body_b >= 0) {  // two of a composite god-object's instruments
        to_scene(c.body_a, c.sphere_a);
        to_scene(c.body_b, c.sphere_b);
      } else {
        const ContactPlane& p =
            planes_.planes[static_cast<std::size_t>(std::clamp(c.sphere_b, 0, kMaxContactPlanes - 1))];
        if (p.node >= 0) continue;  // the net's contact: the scene loop's node contact, above
        to_scene(c.body_a, c.sphere_a);
        c.body_b = p.other_body;
        c.obstacle = p.obstacle;
        c.sphere_b = p.other_sphere;
      }
      out.contacts[static_cast<std::size_t>(count++)] = c;
      deepest = std::max(deepest, c.depth);
    }
    out.contacts_dropped += d.contacts_dropped;
    out.contacts_clamped += d.contacts_clamped;
    out.status |= d.status;
    out.stages_run |= d.stages_run;
    out.solver_iterations = std::max(out.solver_iterations, d.solver_iterations);
    out.solver_residual = std::max(out.solver_residual, d.solver_residual);
  }
  out.num_contacts = count;
  out.max_penetration = deepest;
  if (slot_ >= 0) {  // the graspers: the device step's, their bodies the scene's
    const Slot& s = slot();
    const auto scene_body = [&s](int b) noexcept {
      return b >= 0 && b < static_cast<int>(s.bodies.size()) ? s.bodies[static_cast<std::size_t>(b)] : b;
    };
    for (std::size_t g = 0; g < s.grasps.size() && g < s.device.grasps.size(); ++g) {
      const auto sg = static_cast<std::size_t>(s.grasps[g]);
      if (sg >= out.grasps.size()) continue;
      GraspState& o = out.grasps[sg];
      o = s.device.grasps[g];
      o.body = scene_body(o.body);
      for (GraspPoint& p : o.points) p.jaw = scene_body(p.jaw);
      for (GraspRecord& r : o.log) r.body = scene_body(r.body);
    }
  }
  out.time = static_cast<double>(counters_.device_steps) * slots_.front().device_model.dt;
  out.step_count = counters_.device_steps;
}

}  // namespace numen::core
