#pragma once
/// @file god_object.hpp
/// The multirate god-object (numen/core/multirate.hpp, docs/multirate.md): its settings and
/// counters, and MultirateGodObject, the two loops interleaved on one thread or run by the
/// caller's threads, with tool switching and a single-rate view of both loops.

#include <algorithm>
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/multirate/exchange.hpp"
#include "numen/core/multirate/planes.hpp"
#include "numen/core/types.hpp"

namespace numen::core {

/// Settings of a MultirateGodObject.
struct MultirateSettings {
  int ratio = 1;        ///< N = scene_dt / dt, ≥ 1: device periods per scene period.
  double margin = 0.0;  ///< δ (m, ≥ 0): the proximity model's growth of the god-object's spheres.
  /// Other bodies the device may hold later (tool switching, select()): their god-object and
  /// proximity models are built at construction. Duplicates and the first body are ignored.
  std::vector<int> tools;
  /// Longest step (s, > 0; infinity: no sub-steps) of a scene step where an organ's surface has
  /// folded: a scene step that starts with a triangle of an organ in contact turned more than
  /// 90° from its rest normal (detail::organ_surface_folded()) is taken in ⌈scene_dt /
  /// fold_step⌉ sub-steps, the god-object imposed along its twist (docs/organs.md, "Organs in
  /// multirate": the organ's coarse step folds its surface over the tool).
  double fold_step = 5e-4;
  /// Several devices in one loop (issue 54): a body each of the other devices (1 .. N−1) drives.
  /// Their articulations join the held body's in every god-object (god_object_bodies(): a
  /// composite god-object), so that one device step advances every instrument, each by its own
  /// target (Eq. 6) and with its own Eq. 8 feedback (Data::feedback_group), and their mutual
  /// contacts are the device step's (write_plane_contacts()). Empty: one device.
  std::vector<int> other_devices{};
  /// Free bodies the device loop steps with the god-object (issue 69; docs/multirate-suturing.md,
  /// "Grasping in the device loop"): the bodies its graspers may hold (a peg, a needle), each
  /// its own articulation in every god-object as the other devices' are, but driven by nothing:
  /// gravity, the planes of its contacts with the scene, its contacts with the instruments at
  /// the device rate and, held, the grasp's springs in the device step. The scene loop imposes
  /// them as it imposes the god-object. Empty: none.
  std::vector<int> carried{};
};

/// Counters of a MultirateGodObject. The device loop writes device_steps, stale_models,
/// switches and reset_energy(_max), the scene loop the others.
struct MultirateCounters {
  std::int64_t device_steps = 0;  ///< Device periods stepped.
  std::int64_t scene_steps = 0;   ///< Scene periods stepped (samples taken).
  std::int64_t planes_dropped = 0;  ///< Contacts beyond kMaxContactPlanes, summed over samples.
  std::int64_t planes_max = 0;    ///< Most planes of one sample.
  std::int64_t scene_contacts = 0;  ///< God-object contacts with scene bodies in scene steps.
  std::int64_t switches = 0;      ///< select() calls that changed the god-object.
  /// Device periods stepped on a model older than one scene period: no new model for the held
  /// body in the last N periods (a late scene step, or the first ones after a switch while the
  /// scene loop has not sampled the new body). 0 when both loops share a thread.
  std::int64_t stale_models = 0;
  /// Energy the new planes added at the samples (J): at each new model of the held body, the
  /// planes' elastic energy at the god-object's pose then (plane_elastic_energy()) less that of
  /// the planes they replace, summed where it is positive. A plane set replaced at the sample
  /// is the device loop's one non-passive act (Colgate & Brown 1994): planes that start deeper,
  /// or stiffer, than those they replace hand the god-object energy that no motion of its own
  /// paid, which a scene body moving into the god-object, or an organ pushing it, may account
  /// for, and an impedance wrongly reset may not (docs/multirate.md, "The energy of a new
  /// model"; the observer, Hannaford & Ryu 2002, applied to the model update).
  double reset_energy = 0.0;
  double reset_energy_max = 0.0;  ///< The largest one sample added (J).
  /// Scene steps taken in sub-steps because an organ's surface had folded
  /// (MultirateSettings::fold_step).
  std::int64_t folded_scene_steps = 0;
};

/// A multirate god-object: the device loop steps the held body (the god-object) at dt against
/// the intermediate model; the scene loop steps everything else at scene_dt = N·dt and makes
/// the model (docs/multirate.md). The two loops exchange a MultirateDeviceReport and a
/// MultirateSceneReport; step() interleaves them on one thread in a fixed order (deterministic,
/// bit-identical run to run), device_step() / scene_step() run them on two (the caller's
/// threads and triple buffers: platform::MultirateThreads). One scene period:
///   1. the god-object's poses and twists from the report imposed on its bodies in the
///      scene-loop model (CouplingMode::kDirect: infinitely heavy bodies for the scene's
///      implicit solve; the held body by the target, the others by their body targets; the
///      scene-loop model has not the articulation's joints);
///   2. what each scene body is owed (below) applied to it as the explicit wrench
///      (J, L)/scene_dt of this step (Data::applied_wrench, added to the scene-loop Data's
///      own, restored after the step);
///   3. step() of the scene-loop model (the proximity model at scene_dt = N·dt), whose
///      contact stage detects the contacts, builds the planes from them before any body
///      moves, then cuts the god-object's contacts back to its true spheres (depth − δ):
///      the scene bodies feel the god-object implicitly, as in the single-rate step;
///   4. the impulse those contacts gave each scene body (their effective force over the step,
///      below) is subtracted from what it is owed; the report's new impulses are added; the
///      punctures the device loop asked for are made, and the report carries the planes (less
///      those a needle's passage stands for) and each passage's puncture ties (docs/multirate-suturing.md,
///      "A needle in the device loop").
/// One device period:
///   5. a new model for the held body, if one came, replaces the planes (their carriers
///      restart from the sample);
///   6. step_god_object() at dt;
///   7. the impulse each plane on a scene body gave the god-object, negated, added to that
///      body's running total (its moment about the carrier's centre of mass); each needle's tip
///      tested against its puncture force on its planes (the request in the next report).
/// The effective force of a contact over a step is what the step applied: for the linearly
/// implicit Euler F₀ + K h v₁ + D Δv on the contact's relative velocity, for the symplectic
/// Euler F₀. Momentum: the scene bodies receive what the device loop gave the god-object, the
/// part the scene's own contact did not give them in the same scene period arriving one scene
/// period late; with the owed impulse counted (owed_impulse()), the total is conserved to the
/// solves' tolerance.
///
/// Tool switching (select(), device loop): the device holds one body at a time, or none. Each
/// body it may hold has its own god-object model, device Data and proximity model, built at
/// construction; with none held the scene loop steps the scene alone at scene_dt and the device
/// loop steps nothing. A switch starts the new god-object from its state in the last model and
/// hands the released one's state to the scene loop in the next report; on one thread the next
/// step() starts with a scene period.
///
/// Threads: the device-loop members (device_step, write_report, select, view, device_data,
/// planes) and the scene-loop members (scene_step, scene_data) touch disjoint state; each set
/// from one thread at a time. step() is both.
class MultirateGodObject {
 public:
  /// Builds, for `body` (−1: none held at the start) and each of settings.tools, the god-object
  /// model (dt = scene.dt), its Data, the scene-loop model (make_proximity_model() with
  /// dt = N·scene.dt, the articulation imposed: CouplingMode::kDirect, its joints removed) and
  /// its Data; and the scene-loop model and Data without a god-object (all reset from `scene`). Throws std::invalid_argument with the
  /// message of make_god_object_model() / make_proximity_model(), for N < 1, a margin < 0, no
  /// body at all (`body` −1 and no tools), `body` −1 with other devices (settings.other_devices:
  /// the first device holds a body from the start), or a net on a body in none of their god-objects
  /// and not anchored (the device loop feels a net only through its god-object's node planes,
  /// or an organ's through planes on the god-object's spheres); with graspers (Model::grasps,
  /// held in the device step: make_god_object_model()), for a carried body that is anchored, in
  /// a joint, a net's component or in an instrument's articulation, a grasper whose jaws are not
  /// both in the god-object, and more than one body the device may hold (a switch would drop
  /// what the jaws hold). Allocates (load time).
  MultirateGodObject(const Model& scene, int body, const MultirateSettings& settings);

  /// One device period on one thread: every N-th (the first included, and the first after a
  /// switch) runs the scene period first with this object's own report and model. The device
  /// Data's target, target_twist (Eq. 2) are the caller's to set before. Never allocates,
  /// throws or locks.
  void step() noexcept;

  /// Device loop: the device Data's targets from `scene_data`, a Data of the scene (the run's,
  /// which the control loop fills): the held body's target and target twist (Eq. 2), the
  /// measured device wrench (Data::device_wrench, CouplingMode::kAdmittance), and the body
  /// targets (Eq. 6) and prescribed joint values of the god-object's other bodies and joints.
  /// Never allocates.
  void take_targets(const Data& scene_data) noexcept;
  /// The god-object's bodies (scene indices, god-object model order; empty: none held).
  std::span<const int> god_object() const noexcept;

  /// Device loop: one device period (5–7 above) with `fresh`, the scene loop's newest model if
  /// one came since the last call (nullptr: none). Never allocates, throws, locks or blocks.
  void device_step(const MultirateSceneReport* fresh) noexcept;
  /// Device loop: the report of the device loop's state now. `out` from make_report(). Never
  /// allocates.
  void write_report(MultirateDeviceReport& out) const noexcept;
  /// Scene loop: one scene period (1–4 above) from the device loop's newest report `in`; the
  /// report (the new intermediate model, the scene) into `out` (from make_scene_report()).
  /// Never allocates, throws or locks.
  void scene_step(const MultirateDeviceReport& in, MultirateSceneReport& out) noexcept;
  /// The two loops' reports sized for this object (load time: allocates), holding the
  /// initial state.
  MultirateDeviceReport make_report() const;
  MultirateSceneReport make_scene_report() const;

  /// Device loop: makes `body` the god-object from the next period on (−1: none). The released
  /// body continues in the scene loop from the god-object's pose and twist; the new one starts
  /// from its state in the last model. Returns false, changing nothing, for a body that was not
  /// one of the constructor's, and for −1 with other devices (MultirateSettings::other_devices:
  /// their instruments ride in every god-object, and with none held the scene loop would step
  /// them without their targets). Never allocates.
  bool select(int body) noexcept;

  /// Device loop: what a control loop reads of the device period, into `out` (a Data of the
  /// scene): the god-object's bodies' states and Eq. 8 feedback wrenches (Data::body_feedback,
  /// which platform::ControlLoop carries to the links, Eq. 9), its coupling, device and feedback
  /// wrenches. Part of view(); the real-time step writes only this. Never allocates.
  void write_feedback(Data& out) const noexcept;

  /// Device loop: the single-rate view of both loops, in `out`, a Data of the `scene` the object
  /// was built from (same bodies, joints): every scene body's state from the last model's
  /// snapshot with the god-object's bodies' from the device loop; its coupling, device and
  /// feedback wrenches (body_feedback of the god-object's bodies, zero for the others); the
  /// snapshot's contacts
  /// followed by the device loop's contacts against the planes (body_a the god-object, its
  /// spheres' scene indices, body_b, obstacle and sphere_b the plane's other side); the depth
  /// and counters of both (status and stages_run: the device step's, or'ed with the scene
  /// step's in the period that took its model, each loop's report its own model's
  /// Model::stage_plan; the *_steps counters summed); the joint states (the articulation's
  /// from the device loop, the others from the snapshot) and the larger drift; time and
  /// step_count of the device periods; the graspers' states (Data::grasps: the device step's,
  /// their bodies' indices the scene's). Leaves the caller's fields (held_body, targets,
  /// applied wrenches) alone. Never allocates.
  void view(Data& out) const noexcept;

  const Model& device_model() const noexcept { return slot().device_model; }
  /// The scene-loop model of the god-object the scene loop last sampled.
  const Model& scene_model() const noexcept {
    return scene_slot_ >= 0 ? slots_[static_cast<std::size_t>(scene_slot_)].scene_model
                            : free_scene_model_;
  }
  Data& device_data() noexcept { return slot().device; }  ///< The god-object (body 0).
  Data& scene_data() noexcept { return *scene_; }         ///< The scene loop's bodies.
  const Data& device_data() const noexcept { return slot().device; }
  const Data& scene_data() const noexcept { return *scene_; }
  const ContactPlaneSet& planes() const noexcept { return planes_; }
  int body() const noexcept { return body_; }  ///< The god-object in the scene (−1: none).
  int ratio() const noexcept { return ratio_; }
  /// One thread: the impulse (N·s) and its moment (N·m·s, about the body's centre of mass)
  /// scene body `b` is owed, to be applied at the next scene step.
  Wrench owed_impulse(int b) const noexcept;
  const MultirateCounters& counters() const noexcept { return counters_; }
  /// Device loop: the last device period took a new model (a scene-step boundary).
  bool took_model() const noexcept { return took_model_; }

 private:
  /// One body the device may hold: its god-object (bodies, joints), model and Data, its
  /// scene-loop model.
  struct Slot {
    int body = -1;
    std::vector<int> bodies;       // scene indices, god-object model order
    std::vector<int> joints;       // scene joint indices, god-object model order
    std::vector<int> device_body;  // per scene body: its god-object model index, or −1
    Model device_model;
    Data device;
    Model scene_model;             // the proximity model, the god-object's joints removed
    Model fold_model;              // scene_model at a folded step's sub-step (fold_substeps_ > 1)
    Data scene;                    // the scene loop's Data while this god-object is held
    std::vector<int> scene_joints; // per scene_model joint: its scene joint index
    std::vector<int> grasps;       // per device_model grasper: its scene grasper index
  };
  Slot& slot() noexcept { return slots_[static_cast<std::size_t>(std::max(slot_, 0))]; }
  const Slot& slot() const noexcept { return slots_[static_cast<std::size_t>(std::max(slot_, 0))]; }
  int slot_of(int body) const noexcept;
  void hand_back() noexcept;
  /// Takes the scene report's snapshot, and its planes when they are the held body's: returns
  /// whether it took them.
  bool take_scene_report(const MultirateSceneReport& report) noexcept;

  // The scene loop's period, scene_step(), as its stages in their order (scene_loop.cpp).
  /// What a scene-loop step leaves for the settling after it: whether it was rolled back, and
  /// the time its accepted sub-steps covered (s).
  struct SceneStepOutcome {
    bool rejected = false;
    double time = 0.0;
  };
  /// A switch in `in`: the released god-object's bodies continue in the scene loop from the
  /// device loop's states, no longer imposed (writes seen_switches_, the scene Data's bodies and
  /// body targets).
  void release_switched(const MultirateDeviceReport& in) noexcept;
  /// The god-object `in` holds (−1: none, or not one of the constructor's) and its scene-loop
  /// Data made the current one, which takes the scene's state at a change (writes scene_,
  /// scene_slot_, held_body). Returns that body.
  int enter_scene_slot(const MultirateDeviceReport& in) noexcept;
  /// What the device loop's planes gave each scene body since the last scene step, added to what
  /// it is owed (writes owed_, seen_total_).
  void take_impulses(const MultirateDeviceReport& in) noexcept;
  /// Step 1: the god-object's poses and twists from `in` imposed over the step, the held `body`
  /// by the target, the rest of its articulation by their body targets (writes the scene Data's
  /// target, target_twist, body_targets, bodies).
  void impose_god_object(const MultirateDeviceReport& in, int body) noexcept;
  /// Step 2: what each scene body is owed applied as the explicit wrench of a step of `h` s
  /// (writes base_applied_, the scene Data's applied wrenches; owed_ zeroed).
  void apply_owed(double h) noexcept;
  /// Steps 3 and 4: the scene-loop model stepped (in sub-steps where an organ's surface has
  /// folded), its contact stage building the planes into out.planes, and the impulse its
  /// god-object contacts gave each scene body taken off what it is owed (writes the scene Data,
  /// out.planes, owed_, counters_.folded_scene_steps and scene_contacts).
  SceneStepOutcome step_scene(const MultirateDeviceReport& in, int body,
                              MultirateSceneReport& out) noexcept;
  /// The god-object's imposed poses moved along their twists by `dt` s: a folded step's next
  /// sub-step (writes the scene Data's target and body target poses).
  void advance_imposed(const MultirateDeviceReport& in, int body, double dt) noexcept;
  /// The impulse a (sub-)step of `hs` s of the scene Data's god-object contacts gave each scene
  /// body, already received, so no longer owed (writes owed_, counters_.scene_contacts).
  void receive_contact_impulses(std::span<const int> device_body, bool implicit,
                                double hs) noexcept;
  /// After the step: a rolled-back step's remaining owed impulse kept, the scene Data's own
  /// applied wrenches restored and the god-object's bodies set to `in`'s states (writes owed_,
  /// the scene Data's applied wrenches and bodies).
  void settle_after_step(const MultirateDeviceReport& in, const SceneStepOutcome& stepped,
                         double h) noexcept;
  /// The report for the device loop: the scene-step counters, the sampled god-object and period
  /// and the snapshot of the scene (writes counters_, out.body, out.sample_period, out.scene).
  void write_scene_report(const MultirateDeviceReport& in, int body,
                          MultirateSceneReport& out) noexcept;
  /// Device loop, before the god-object's step: the sample's puncture ties (PunctureTie) as the
  /// device Data's sliding ties — each material point held on the line along the needle's arc
  /// tangent at its closest arc point, by the needle's tie (NeedleModel::tie_stiffness,
  /// tie_damping, friction), none where the point is off the arc (writes Data::sliding_ties,
  /// tie_slots_). After it: each tie's force back into PunctureTie::force and its material point
  /// carried on at its sample velocity for the period (writes planes_.ties).
  void hold_on_puncture_ties() noexcept;
  void carry_puncture_ties() noexcept;
  /// Device loop: each needle of the god-object's tip force along its tangent on the planes this
  /// period, and its puncture request (MultirateDeviceReport::puncture_requests) set, kept or
  /// withdrawn (writes tip_forces_, puncture_requests_).
  void test_punctures() noexcept;
  /// Scene loop: the punctures the device loop asked for in `in`, made on the scene Data
  /// (detail::puncture_on_request(); writes its needles).
  void make_requested_punctures(const MultirateDeviceReport& in) noexcept;
  /// Scene loop: the node planes of each needle of the god-object in a passage that its puncture
  /// ties stand for, removed from `planes`: those on its part inside the tissue (built at the
  /// step's start, before a puncture the step made) and those of the nodes its points are tied
  /// to (whose push on the needle is the tie's) (writes planes.planes, planes.count).
  void drop_passage_planes(ContactPlaneSet& planes) const noexcept;
  /// The puncture ties of the needles of the god-object (PunctureTie) from the scene Data's
  /// passages, their material points at the step's end (writes out.ties, out.tie_count).
  void write_puncture_ties(ContactPlaneSet& out) const noexcept;
  /// The threads' reactions on the god-object's bodies in the scene step (ThreadPull, from
  /// Data::thread_reactions; writes out.pulls, out.pull_count).
  void write_thread_pulls(ContactPlaneSet& out) const noexcept;
  /// Device loop, at a new sample: its thread pulls as the device Data's applied wrenches, the
  /// other bodies' zero (writes the device Data's Data::applied_wrench).
  void apply_thread_pulls() noexcept;
  /// The scene loop's current god-object: its bodies (scene indices; empty without one).
  std::span<const int> scene_god() const noexcept;
  /// ... per scene body its god-object model index or −1 (empty without one).
  std::span<const int> scene_device_body() const noexcept;
  /// ... and the scene-loop model of a folded step's sub-step.
  const Model& scene_fold_model() const noexcept;

  int ratio_;
  double margin_;
  bool other_devices_ = false;    // several devices: a body is held throughout (select())
  int fold_substeps_ = 1;         // sub-steps of a folded scene step: ⌈scene_dt / fold_step⌉
  std::vector<Slot> slots_;       // one per body the device may hold (at least one)
  Model free_scene_model_;        // the scene loop without a god-object
  Model free_fold_model_;         // ... at a folded step's sub-step (fold_substeps_ > 1)
  // Device loop.
  int body_;
  int slot_ = -1;                 // the held body's slot; -1: none held
  ContactPlaneSet planes_;
  std::vector<Wrench> impulse_total_;   // per scene body, running totals (report)
  StepOutputs snapshot_;                // the scene, from the last scene report
  std::int64_t period_ = 0;       // device periods since construction or the last switch
  std::int64_t periods_since_model_ = 0;
  std::int64_t switches_ = 0;
  int released_body_ = -1;
  std::vector<BodyState> released_states_;
  bool took_model_ = false;       // the last device period took a new model
  std::vector<double> puncture_requests_;  // per needle (MultirateDeviceReport::puncture_requests)
  std::vector<double> tip_forces_;         // per needle: the tip's force along it on the planes (N)
  std::array<int, kMaxPunctureTies> tie_slots_{};  // per puncture tie: its sliding tie, or −1
  // Scene loop.
  Data free_scene_;               // the scene loop's Data while nothing is held
  std::vector<int> free_joints_;  // identity: the free model's joints are the scene's
  Data* scene_ = nullptr;         // the scene loop's current Data (its slot's, or free_scene_)
  int scene_slot_ = -1;
  std::int64_t seen_switches_ = 0;
  std::vector<Wrench> owed_;          // per scene body
  std::vector<Wrench> seen_total_;    // the report's impulse_total at the last scene step
  std::vector<Wrench> base_applied_;  // the scene-loop Data's own applied wrenches
  // Scene loop, nets on the god-object: scratch of the node planes (detail::NodePlaneScratch).
  std::vector<int> node_slot_;
  std::vector<int> slot_node_;
  std::vector<Mat3> node_stiffness_;
  std::vector<int> plane_slot_;
  std::vector<double> planes_stiffness_;
  std::vector<double> planes_depth_;
  std::vector<Vec3> node_force_;
  std::vector<std::int32_t> plane_springs_;
  // One thread (step()).
  MultirateDeviceReport report_;
  MultirateSceneReport scene_report_;
  MultirateCounters counters_;
};

}  // namespace numen::core
