/// @file scene_loop.cpp
/// The scene loop's period of a multirate god-object (MultirateGodObject::scene_step(),
/// numen/core/multirate/god_object.hpp, docs/multirate.md): a list of named stages, as
/// core::step's, each a member that says what it writes.

#include "numen/core/multirate/god_object.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "numen/core/collision.hpp"
#include "numen/core/data.hpp"
#include "numen/core/features.hpp"
#include "numen/core/model.hpp"
#include "numen/core/needle.hpp"
#include "numen/core/net_collision.hpp"
#include "numen/core/rigid_body.hpp"
#include "numen/core/step.hpp"
#include "numen/core/step_stages.hpp"

#include "scratch/data_scratch.hpp"
#include "multirate/contact.hpp"
#include "multirate/net.hpp"
#include "needle/needle_passage.hpp"
#include "numen/core/multirate/planes.hpp"

namespace numen::core {
namespace {

using detail::copy_counts;
using detail::effective_contact_force;
using detail::god_object_contact;
using detail::in_god_object;

/// The scene loop's contact stage: detection, the planes of the god-object's contacts (before
/// any body moves), then those contacts cut back to the god-object's true spheres (the
/// proximity model grew them by the margin): depth − δ, the middle of the overlap δ/2 back
/// towards the god-object; a contact left without depth is dropped, and so is one between two
/// bodies of the god-object (the scene-loop model has not their joints). With nets and a
/// god-object (SampleContext::node_planes), the node contacts likewise: detected, their node
/// planes built, cut back.
struct SampleContext {
  ContactPlaneSet* planes;
  std::span<const int> device_body;  // per scene body: god-object model index or −1
  double margin;
  double device_dt;
  detail::NodePlaneScratch node_scratch;
  bool node_planes;  // the node contacts' planes too: a god-object sampled and nets
};


void detect_and_build_planes(const Model& model, Data& data, const SampleContext* c) noexcept {
  detect_contacts(model, data);
  build_contact_planes(model, data, c->device_body, c->device_dt, *c->planes);
  int kept = 0;
  double deepest = 0.0;
  const int n = std::clamp(data.num_contacts, 0, kMaxContacts);
  for (int i = 0; i < n; ++i) {
    Contact k = data.contacts[static_cast<std::size_t>(i)];
    // Two bodies of the god-object's articulation: its joints are the device loop's, and one
    // articulation never collides with itself (ArticulationTopology::body_tree).
    if (in_god_object(c->device_body, k.body_a) && in_god_object(c->device_body, k.body_b)) continue;
    bool on_a = false;
    if (c->margin > 0.0 && god_object_contact(k, c->device_body, on_a)) {
      k.depth -= c->margin;
      if (!(k.depth > 0.0)) continue;
      k.position += (0.5 * c->margin) * (on_a ? k.normal : Vec3(-k.normal));
    }
    deepest = std::max(deepest, k.depth);
    data.contacts[static_cast<std::size_t>(kept++)] = k;
  }
  data.num_contacts = kept;
  data.max_penetration = deepest;
  if constexpr (kWithDeformable) {
    if (c->node_planes) {
      detect_node_contacts(model, data);
      // No plane on a needle's part inside the tissue: its puncture ties hold it (PunctureTie).
      // Dropped first: a needle inside is not a sphere past the surface.
      if (!model.needles.empty()) detail::drop_needles_inside_contacts(model, data);
      detail::drop_back_face_contacts(model, data, c->device_body, c->margin);
      detail::build_node_planes(model, data, c->device_body, c->margin, c->node_scratch, *c->planes);
      // The look-ahead where the net steps slower than the device loop (at a rate ratio of 1
      // the scene step is the single-rate step).
      detail::cut_back_node_contacts(model, data, c->device_body, c->margin, deepest,
                                     model.dt > 1.5 * c->device_dt ? model.dt : 0.0);
    }
  }
}

/// One scene-loop step split at its contacts (step.hpp): its contact stage is
/// detect_and_build_planes() where the model can collide (Model::stage_plan); the node contacts
/// are detected as step() does where that stage does not build their planes.
void step_sample(const Model& model, Data& data, const SampleContext& c) noexcept {
  step_to_contacts(model, data);
  const bool contacts = (model.stage_plan & kStageContacts) != 0;
  if (contacts) detect_and_build_planes(model, data, &c);
  if constexpr (kWithDeformable) {
    if ((model.stage_plan & kStageNodeContacts) && !(contacts && c.node_planes))
      detect_node_contacts(model, data);  // sets its bit
  }
  step_from_contacts(model, data);
}

}  // namespace

void MultirateGodObject::scene_step(const MultirateDeviceReport& in, MultirateSceneReport& out) noexcept {
  release_switched(in);                       //    a switch hands the released god-object back
  const int body = enter_scene_slot(in);      //    the sampled god-object's scene-loop Data
  const double h = scene_model().dt;
  take_impulses(in);                          //    what the device loop's planes gave the bodies
  impose_god_object(in, body);                // 1. the god-object imposed (kDirect)
  apply_owed(h);                              // 2. what each body is owed, as its wrench
  const SceneStepOutcome stepped = step_scene(in, body, out);  // 3., 4. the step, its impulses
  settle_after_step(in, stepped, h);          //    the rest owed, the wrenches, the god-object
  make_requested_punctures(in);               //    the punctures the device loop found
  write_scene_report(in, body, out);           //    the report for the device loop
}

void MultirateGodObject::release_switched(const MultirateDeviceReport& in) noexcept {
  if (in.switches == seen_switches_) return;
  seen_switches_ = in.switches;
  const int released = in.released_body >= 0 ? slot_of(in.released_body) : -1;
  if (released < 0) return;
  const Slot& r = slots_[static_cast<std::size_t>(released)];
  for (std::size_t i = 0; i < r.bodies.size() && i < in.released_states.size(); ++i) {
    const auto b = static_cast<std::size_t>(r.bodies[i]);
    scene_->bodies[b] = in.released_states[i];
    scene_->body_targets[b].enabled = false;  // no longer imposed
  }
}

int MultirateGodObject::enter_scene_slot(const MultirateDeviceReport& in) noexcept {
  const int body = in.body >= 0 && slot_of(in.body) >= 0 ? in.body : -1;
  const int next_slot = body >= 0 ? slot_of(body) : -1;
  if (next_slot != scene_slot_) {  // another scene-loop model: its Data takes the scene's state
    Data& next = next_slot >= 0 ? slots_[static_cast<std::size_t>(next_slot)].scene : free_scene_;
    for (std::size_t b = 0; b < next.bodies.size() && b < scene_->bodies.size(); ++b) {
      next.bodies[b] = scene_->bodies[b];
      next.applied_wrench[b] = scene_->applied_wrench[b];
      next.body_targets[b] = scene_->body_targets[b];
    }
    detail::copy_nets(*scene_, next);  // same sizes: the scene-loop models all have the scene's nets
    copy_counts(*scene_, next);  // go on from the scene's: the view reports the current Data's
    next.time = scene_->time;
    next.step_count = scene_->step_count;
    scene_ = &next;
    scene_slot_ = next_slot;
  }
  scene_->held_body = body;
  return body;
}

// Empty spans without a slot: no function-local static, whose first use registers its
// destructor with atexit(), which may allocate (the scene step never allocates).
std::span<const int> MultirateGodObject::scene_god() const noexcept {
  return scene_slot_ >= 0 ? std::span<const int>(slots_[static_cast<std::size_t>(scene_slot_)].bodies)
                          : std::span<const int>();
}

std::span<const int> MultirateGodObject::scene_device_body() const noexcept {
  return scene_slot_ >= 0
             ? std::span<const int>(slots_[static_cast<std::size_t>(scene_slot_)].device_body)
             : std::span<const int>();
}

const Model& MultirateGodObject::scene_fold_model() const noexcept {
  return scene_slot_ >= 0 ? slots_[static_cast<std::size_t>(scene_slot_)].fold_model
                          : free_fold_model_;
}

void MultirateGodObject::take_impulses(const MultirateDeviceReport& in) noexcept {
  const std::size_t nb = owed_.size();
  for (std::size_t b = 0; b < nb && b < in.impulse_total.size(); ++b) {
    owed_[b].force += in.impulse_total[b].force - seen_total_[b].force;
    owed_[b].torque += in.impulse_total[b].torque - seen_total_[b].torque;
    seen_total_[b] = in.impulse_total[b];
  }
}

void MultirateGodObject::impose_god_object(const MultirateDeviceReport& in, int body) noexcept {
  const std::span<const int> god = scene_god();
  for (std::size_t i = 0; i < god.size() && i < in.states.size(); ++i) {
    const auto b = static_cast<std::size_t>(god[i]);
    const BodyState& g = in.states[i];
    Pose pose;
    pose.position = g.position;
    pose.orientation = g.orientation;
    Twist twist;
    twist.linear = g.linear_velocity;
    twist.angular = g.angular_velocity;
    if (god[i] == body) {
      scene_->target = pose;
      scene_->target_twist = twist;
    } else {
      BodyTarget& t = scene_->body_targets[b];
      t.pose = pose;
      t.twist = twist;
      t.enabled = true;
    }
    scene_->bodies[b] = g;
  }
}

void MultirateGodObject::apply_owed(double h) noexcept {
  const std::size_t nb = owed_.size();
  for (std::size_t b = 0; b < nb; ++b) {
    base_applied_[b] = scene_->applied_wrench[b];
    scene_->applied_wrench[b].force += owed_[b].force / h;
    scene_->applied_wrench[b].torque += owed_[b].torque / h;
    owed_[b] = Wrench{};
  }
}

MultirateGodObject::SceneStepOutcome MultirateGodObject::step_scene(
    const MultirateDeviceReport& in, int body, MultirateSceneReport& out) noexcept {
  const Model& model = scene_model();
  const std::span<const int> device_body = scene_device_body();
  SampleContext context{&out.planes, std::span<const int>(device_body.data(), device_body.size()),
                        body >= 0 ? margin_ : 0.0, slots_.front().device_model.dt,
                        detail::NodePlaneScratch{node_slot_, slot_node_, node_stiffness_, plane_slot_,
                                                 planes_stiffness_, planes_depth_, node_force_,
                                                 plane_springs_},
                        body >= 0 && model.num_nets() > 0};
  // Where an organ's surface has folded under the tool, the step is taken in sub-steps of at
  // most MultirateSettings::fold_step (fold_substeps_ of them), the god-object imposed along its
  // twist. Both models are finalized at construction and never written: a folded step's dt is
  // the second's.
  int substeps = 1;
  if constexpr (kWithDeformable) {
    if (fold_substeps_ > 1 && detail::organ_surface_folded(model, *scene_)) substeps = fold_substeps_;
  }
  if (substeps > 1) ++counters_.folded_scene_steps;
  const Model& step_model = substeps > 1 ? scene_fold_model() : model;
  const double hs = step_model.dt;  // h / substeps
  const bool implicit = model.integrator == Integrator::kLinearlyImplicitEuler;
  SceneStepOutcome stepped;
  for (int sub = 0; sub < substeps; ++sub) {
    if (sub > 0) {
      if constexpr (kWithDeformable) detail::drop_look_ahead_contacts(*scene_);
      advance_imposed(in, body, hs);
    }
    step_sample(step_model, *scene_, context);
    stepped.rejected = (scene_->status & kNonFinite) != 0;
    if (stepped.rejected) break;
    stepped.time += hs;
    if (body >= 0) receive_contact_impulses(device_body, implicit, hs);
  }
  if constexpr (kWithDeformable) detail::drop_look_ahead_contacts(*scene_);
  return stepped;
}

void MultirateGodObject::advance_imposed(const MultirateDeviceReport& in, int body,
                                         double dt) noexcept {
  const std::span<const int> god = scene_god();
  for (std::size_t i = 0; i < god.size() && i < in.states.size(); ++i) {
    Pose& pose = god[i] == body ? scene_->target
                                : scene_->body_targets[static_cast<std::size_t>(god[i])].pose;
    const Twist& twist = god[i] == body
                             ? scene_->target_twist
                             : scene_->body_targets[static_cast<std::size_t>(god[i])].twist;
    pose.position += dt * twist.linear;
    pose.orientation = integrate_orientation(pose.orientation, twist.angular, dt);
  }
}

void MultirateGodObject::receive_contact_impulses(std::span<const int> device_body, bool implicit,
                                                  double hs) noexcept {
  const int n = std::clamp(scene_->num_contacts, 0, kMaxContacts);
  for (int i = 0; i < n; ++i) {
    const Contact& c = scene_->contacts[static_cast<std::size_t>(i)];
    const ContactTerm& t = scene_->scratch->solver.contact_terms[static_cast<std::size_t>(i)];
    bool on_a = false;
    if (!t.active || !god_object_contact(c, device_body, on_a) || c.body_a < 0 || c.body_b < 0) continue;
    const auto a = static_cast<std::size_t>(c.body_a);
    const auto b = static_cast<std::size_t>(c.body_b);
    const std::vector<BodyState>& before = scene_->scratch->solver.saved_state;  // the step's start
    const Vec3 f = effective_contact_force(c, t, implicit, hs, before[a], scene_->bodies[a],
                                           &before[b], &scene_->bodies[b]);
    // The other body's share: −f if it is b, +f if it is a.
    const Vec3 on_other = on_a ? Vec3(-f) : f;
    const Vec3& r = on_a ? t.r_b : t.r_a;
    Wrench& w = owed_[on_a ? b : a];
    w.force -= hs * on_other;
    w.torque -= hs * r.cross(on_other);
    ++counters_.scene_contacts;
  }
}

void MultirateGodObject::settle_after_step(const MultirateDeviceReport& in,
                                           const SceneStepOutcome& stepped, double h) noexcept {
  const std::size_t nb = owed_.size();
  for (std::size_t b = 0; b < nb; ++b) {
    if (stepped.rejected) {  // rolled back: what was owed over the rest of the step is still owed
      owed_[b].force +=
          (h - stepped.time) * (scene_->applied_wrench[b].force - base_applied_[b].force);
      owed_[b].torque +=
          (h - stepped.time) * (scene_->applied_wrench[b].torque - base_applied_[b].torque);
    }
    scene_->applied_wrench[b] = base_applied_[b];
  }
  const std::span<const int> god = scene_god();
  for (std::size_t i = 0; i < god.size() && i < in.states.size(); ++i)
    scene_->bodies[static_cast<std::size_t>(god[i])] = in.states[i];
}

void MultirateGodObject::write_scene_report(const MultirateDeviceReport& in, int body,
                                            MultirateSceneReport& out) noexcept {
  ++counters_.scene_steps;
  counters_.planes_dropped += out.planes.dropped;
  counters_.planes_max = std::max<std::int64_t>(counters_.planes_max, out.planes.count);
  // The model: the planes (the step's contact stage), the tools' states, the snapshot of the scene.
  out.body = body;
  out.sample_period = in.period;
  drop_passage_planes(out.planes);
  write_puncture_ties(out.planes);
  write_thread_pulls(out.planes);
  const std::vector<int>& scene_joints =
      scene_slot_ >= 0 ? slots_[static_cast<std::size_t>(scene_slot_)].scene_joints : free_joints_;
  const std::span<const int> device_body = scene_device_body();
  StepOutputs& snap = out.scene;
  // The scene loop's Data (its joint j is the scene's scene_joints[j]), then only its contacts
  // not on the god-object (those on it are the device loop's), in order.
  copy_outputs(*scene_, scene_joints, snap);
  int count = 0;
  for (int i = 0; i < snap.num_contacts; ++i) {
    const Contact c = snap.contacts[static_cast<std::size_t>(i)];
    bool on_a = false;
    if (god_object_contact(c, device_body, on_a)) continue;  // the device loop's
    snap.contacts[static_cast<std::size_t>(count++)] = c;
  }
  snap.num_contacts = count;
}

void MultirateGodObject::make_requested_punctures(const MultirateDeviceReport& in) noexcept {
  if constexpr (!kWithDeformable) return;
  const Model& model = scene_model();
  for (std::size_t k = 0; k < model.needles.size() && k < in.puncture_requests.size(); ++k)
    if (in.puncture_requests[k] > 0.0 && model.needles[k].puncture_on_request)
      detail::puncture_on_request(model, *scene_, static_cast<int>(k), in.puncture_requests[k]);
}

void MultirateGodObject::drop_passage_planes(ContactPlaneSet& planes) const noexcept {
  if constexpr (!kWithDeformable) return;
  const Model& model = scene_model();
  const std::span<const int> device_body = scene_device_body();
  for (std::size_t k = 0; k < model.needles.size() && k < scene_->needles.size(); ++k) {
    const NeedleModel& n = model.needles[k];
    const NeedleState& st = scene_->needles[k];
    if (st.num_punctures <= 0 || !in_god_object(device_body, n.body)) continue;
    const int local = device_body[static_cast<std::size_t>(n.body)];
    const auto tied = [&](int node) noexcept {
      for (int i = 0; i < st.num_punctures; ++i) {
        const int face = st.punctures[static_cast<std::size_t>(i)].face;
        if (face < 0 || face >= static_cast<int>(model.net_faces.size())) continue;
        for (int v : model.net_faces[static_cast<std::size_t>(face)])
          if (v == node) return true;
      }
      return false;
    };
    int kept = 0;
    const int count = std::clamp(planes.count, 0, kMaxContactPlanes);
    for (int i = 0; i < count; ++i) {
      const ContactPlane& p = planes.planes[static_cast<std::size_t>(i)];
      if (p.node >= 0 && p.body == local &&
          ((p.sphere >= 0 && detail::needle_sphere_inside(n, st, p.sphere)) || tied(p.node)))
        continue;
      planes.planes[static_cast<std::size_t>(kept++)] = p;
    }
    planes.count = kept;
  }
}

void MultirateGodObject::write_puncture_ties(ContactPlaneSet& out) const noexcept {
  out.tie_count = 0;
  if constexpr (!kWithDeformable) return;
  const Model& model = scene_model();
  const std::span<const int> device_body = scene_device_body();
  for (std::size_t k = 0; k < model.needles.size() && k < scene_->needles.size(); ++k) {
    const NeedleModel& n = model.needles[k];
    if (!in_god_object(device_body, n.body)) continue;  // a needle of the scene loop's own
    const NeedleState& st = scene_->needles[k];
    for (int i = 0; i < st.num_punctures && out.tie_count < kMaxPunctureTies; ++i) {
      const NeedlePuncture& p = st.punctures[static_cast<std::size_t>(i)];
      if (p.face < 0 || p.face >= static_cast<int>(model.net_faces.size())) continue;
      const std::array<int, 3>& v = model.net_faces[static_cast<std::size_t>(p.face)];
      PunctureTie& t = out.ties[static_cast<std::size_t>(out.tie_count++)];
      t.needle = static_cast<int>(k);
      t.body = device_body[static_cast<std::size_t>(n.body)];
      t.anchor.setZero();
      t.velocity.setZero();
      for (int j = 0; j < 3; ++j) {  // the material point at the step's end
        const NodeState& node = scene_->nodes[static_cast<std::size_t>(v[static_cast<std::size_t>(j)])];
        t.anchor += p.weights[j] * node.position;
        t.velocity += p.weights[j] * node.velocity;
      }
      t.force.setZero();
    }
  }
}

void MultirateGodObject::write_thread_pulls(ContactPlaneSet& out) const noexcept {
  out.pull_count = 0;
  const std::span<const int> device_body = scene_device_body();
  const std::vector<Wrench>& reactions = scene_->thread_reactions;  // empty without a thread
  for (std::size_t b = 0; b < reactions.size() && b < device_body.size(); ++b) {
    const Wrench& w = reactions[b];
    if (device_body[b] < 0 || (w.force.isZero(0.0) && w.torque.isZero(0.0)) || out.pull_count >= kMaxThreadPulls)
      continue;
    out.pulls[static_cast<std::size_t>(out.pull_count++)] = ThreadPull{device_body[b], w};
  }
}

}  // namespace numen::core
