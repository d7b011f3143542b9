#pragma once
/// @file scene.hpp
/// A scene file (TOML, see docs/scenes.md) loaded into everything a run needs:
/// the compiled core::Model, the instrument's hal::DeviceConfig, the SimBus
/// settings, the target trajectory (world frame, at the control period) and
/// the tool-switching events. Load time only: allocates, throws InputError
/// naming file, line, column and key.

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "numen/core/model.hpp"
#include "numen/core/net_material.hpp"
#include "numen/hal/device/admittance_device.hpp"
#include "numen/hal/device/device_config.hpp"
#include "numen/hal/transport/sim_bus.hpp"
#include "numen/platform/device_binding.hpp"
#include "numen/sim/device/admittance_hand.hpp"
#include "numen/sim/device/hand.hpp"
#include "numen/sim/device/hand_servo.hpp"
#include "numen/sim/device/plant_motion.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/input/trajectory.hpp"
#include "numen/sim/scene/passivity_lint.hpp"

namespace numen::sim {

/// Longest run a scene's `duration` or `numen run --duration` may ask for (s):
/// 1e7 s, about 116 days of simulated or paced time. Beyond it the step count
/// duration / dt no longer fits the run's arithmetic; no experiment needs it.
inline constexpr double kMaxRunDuration = 1e7;

/// At `time_s`, the device lets go of its body and holds `body` (-1: none).
/// The paper's construction game picks which block the hand holds.
struct AttachEvent {
  double time_s = 0.0;
  int body = -1;
};

/// An OpenIGTLink tracker as the pose tracker's encoders (scene `[device.igtl]`;
/// docs/openigtlink.md): what `numen run --bus igtl` connects to and how it turns a TRANSFORM
/// into the tool tip's world pose, tip = registration · [R, metres_per_unit · t] · calibration
/// (hal/igtl/igtl_tracker_bus.hpp). Plain data: the scene reads it whatever the
/// build (NUMEN_WITH_OPENIGTLINK decides whether a run can use it).
struct IgtlTrackerScene {
  std::string host = "127.0.0.1";  ///< The OpenIGTLink server (PLUS, a bridge, numen igtl-replay).
  std::uint16_t port = 18944;      ///< Its TCP port (OpenIGTLink's default 18944).
  /// The tool's device name, e.g. "StylusToTracker" (its TRANSFORM, POSITION or QTRANS messages).
  std::string device_name;
  double metres_per_unit = 1e-3;   ///< `units`: "mm" (PLUS) 1e-3, "cm" 1e-2, "m" 1.
  std::string units = "mm";        ///< As the scene gives it.
  core::Pose calibration;          ///< Tool tip (the tracked frame) in the marker's frame, m.
  core::Pose registration;         ///< Tracker frame in the scene's world, m.
  /// `registration = "TrackerToScene"`: the registration is the TRANSFORM of this device name,
  /// read at start (replaces `registration`); empty: the fixed transform.
  std::string registration_name;
  double registration_wait_s = 5.0;  ///< `registration_wait`: the longest wait for it, s.
  /// Where `registration` is in the scene file (file, 1-based line and column), for the error
  /// when the named TRANSFORM never comes.
  std::string registration_file;
  int registration_line = 0, registration_column = 0;
};

/// An admittance device (scene `[device.admittance]`, with `coupling = "admittance"`; paper
/// Fig. 2 note): the force sensor and csp RPDOs, and the emulated device's hand and drives.
struct AdmittanceScene {
  hal::AdmittanceConfig config;               ///< Validated against Scene::device.
  /// Time constant of each drive's tracking of its csp target, s (`drive_lag`; 0: ideal).
  double drive_lag_s = kDefaultDriveLagS;
};

/// Triangles of one net's surface, as node indices local to the net (0 .. node_count − 1),
/// counter-clockwise seen from outside: for display (the dynamics use the springs).
using NetTriangles = std::vector<std::array<int, 3>>;

/// How one organ's net was made from its mesh (docs/fine-surface.md; `numen info` reports
/// it). A mesh file of more vertices than the net asked for (scene keys
/// `nodes` or `edge_length`, else kDefaultNetNodes) is simplified into the net, and the file's
/// own surface rides on it as the net's fine surface (core::add_net_surface(); the model's
/// NetModel::surface_point_count and surface_face_count). Otherwise the mesh is the net.
struct NetLoad {
  int mesh_vertices = 0;   ///< Vertices of the mesh as read (file or built-in).
  int mesh_triangles = 0;  ///< Its triangles.
  /// The node count asked for: `nodes`, or the count `edge_length` gives, or kDefaultNetNodes;
  /// the mesh's own vertex count where the mesh is the net.
  int nodes_asked = 0;
  std::string nodes_from;   ///< Which rule set nodes_asked: "nodes", "edge_length", "default", "mesh".
  bool simplified = false;  ///< The net was simplified from the mesh, which is its fine surface.
  bool cache_loaded = false;  ///< That net was read from its cache file (scene key `cache`).
  /// Thread CPU time (s) of the simplification (or the cache file's read) and the map (nearest
  /// net triangle of each fine vertex, core::add_net_surface()); 0 when not simplified.
  double simplify_seconds = 0.0;
  /// The net is given by its material (docs/tissue.md): its surface's volume tetrahedralised,
  /// interior_nodes more nodes inside, tetrahedra cells, the constants derived.
  bool material = false;
  int interior_nodes = 0;  ///< Nodes inside the surface (after the surface's own).
  int tetrahedra = 0;      ///< Cells of the volume mesh.
  core::MaterialNetConstants material_constants;  ///< What core::add_material_net() derived.
  /// The settings the material net was made with (its material, the load patch radius and node
  /// radius as given, 0 where derived); default-constructed for a net given per spring.
  core::MaterialNetSettings tissue;
};

/// The node count of an organ's net made from a mesh file when the scene asks for none: a mesh
/// of more vertices is simplified to it (the shipped organ, 1002 vertices, is its own net).
inline constexpr int kDefaultNetNodes = 1024;

/// A multirate god-object (scene `[multirate]`; docs/multirate.md, core::MultirateGodObject):
/// the device loop at the scene's dt, the scene loop at scene_dt_s = ratio · dt.
struct MultirateScene {
  double scene_dt_s = 0.0;  ///< The scene loop's period (s).
  int ratio = 1;            ///< N = scene_dt / dt ≥ 1: device periods per scene period.
  double margin_m = 0.0;    ///< Proximity margin δ (m): the god-object's spheres grown by it.
  /// Longest step (s) of a scene step where an organ's surface has folded under the tool
  /// (core::MultirateSettings::fold_step; scene key `fold_step`, default 0.5 ms).
  double fold_step_s = 5e-4;
  /// The bodies the device holds in the run (the initially held one, then the events' in order).
  std::vector<int> tools;
  /// Several devices: the first body each of Scene::extra_devices drives (its binding's first
  /// link to a body), whose articulation joins the god-object (core::MultirateSettings::
  /// other_devices).
  std::vector<int> other_devices;
  /// With graspers: the free bodies the device loop steps with the god-object, what the jaws may
  /// hold (core::MultirateSettings::carried): every body not anchored, in no joint, no net's
  /// component and in no device's articulation.
  std::vector<int> carried;
};

/// One device of a scene beyond the first: entries 1 .. N−1 of a `[[device]]` array
/// (docs/scenes.md, "Several devices"); entry 0 is the scene's own fields (Scene::device,
/// binding, trajectory, hand, plant, model.feedback), as for a single `[device]`; its Eq. 8
/// gains are in the model (core::Model::extra_feedback). Each device is an impedance
/// instrument on the scene's one simulated bus (its own CANopen nodes: no node id or COB-ID of
/// another device), driving the bodies whose `link` key names it (`device = "<name>"` on the
/// [[body]] table) and the joints whose `prescribed` table names it.
struct SceneDevice {
  hal::DeviceConfig device;  ///< Validated; control_period_s = model.dt; name unique in the scene.
  /// Which bodies its links drive and which prescribed joints its axes impose. No rigid binding
  /// (link 0 → the held body): the held body is device 0's (`attach`).
  platform::DeviceBinding binding;
  /// Target of its tool frame in the world: its `[device.trajectory]`, else the scene's
  /// `[trajectory]` (same units and frame as Scene::trajectory).
  Trajectory trajectory;
  HandSettings hand;  ///< Its simulated hand (`[device.hand]`).
  /// Its mechanics (`[device.plant]`; unset: the emulated instrument replays its trajectory).
  std::optional<DevicePlantSettings> plant;
  /// Its hand's sight (`[device.trajectory.servo]` and its segments' `servo_target`;
  /// hand_servo.hpp): unset, the hand follows its script blind.
  std::optional<HandServoSpec> servo;
  std::string trocar_note;  ///< How its trocar point was placed; empty if not a trocar.
};

/// A scene's task (`[task]`; docs/grasping.md, "Peg transfer"): the bodies a bimanual task moves
/// and the pegs they go to. The run's summary counts each object's grasps, hand-overs, drops and
/// whether it ended on a peg (task_summary.hpp), from the graspers' logs and the final poses.
struct SceneTask {
  std::vector<int> objects;  ///< Body indices (dynamic, distinct), in `objects` order.
  std::vector<int> pegs;     ///< Obstacle indices (capsules), in `pegs` order.
  /// An object is on a peg when its centre of mass is within this distance (m, > 0) of the
  /// peg's axis segment (the capsule's from–to).
  double reach = 0.005;
};

/// Where a needle should go into tissue and come out, pass by pass (`[[needle]]` `entry_mark`,
/// `exit_mark`: a point, or a list of points, one per pass; docs/suturing.md, "The suturing
/// scene"): world points (m) on a deformable's rest surface. The run's summary gives the distance
/// of the needle's k-th pass's entry and exit (an entry followed by an exit) from the k-th marks
/// (needle.*). Either list may be empty (no such mark).
struct NeedleMarks {
  std::vector<core::Vec3> entry;
  std::vector<core::Vec3> exit;
};

/// Everything a run of a scene needs.
struct Scene {
  std::string file;          ///< Path of the scene file, as given.
  std::string name;
  std::string description;
  core::Model model;         ///< Finalized.
  hal::DeviceConfig device;  ///< Validated; control_period_s = model.dt.
  /// Which bodies the device's links drive and which joints its axes impose
  /// (bodies' `link` keys, joints' `prescribed`); the rigid binding (link 0 →
  /// the held body) when the scene binds nothing.
  platform::DeviceBinding binding;
  hal::SimBusSettings bus;   ///< The simulated bus between controller and instrument.
  /// Bus time after SYNC at which the controller reads the encoder answers and
  /// steps (s, in (2·latency, dt)): one SYNC round trip fits in the period.
  double compute_phase_s = 0.0;
  /// Target of the instrument's tool frame (trocar instrument: the tip) in the
  /// world, sampled at model.dt; empty when has_trajectory is false. Not the held body's
  /// target: InstrumentTargets (instrument_targets.hpp) turns a sample into the bodies'.
  Trajectory trajectory;
  /// The scene has a [trajectory]. Only a scene loaded with SceneOverrides::caller_steps may
  /// leave it out (run_missing then says so).
  bool has_trajectory = true;
  /// The scene has a [device]. Only a scene loaded with SceneOverrides::caller_steps may leave
  /// it out: `device` is then hal::make_default_pose_tracker_config() (no drives, identity base
  /// and tool offset: a sample is the held body's COM-frame target), the feedback gains are
  /// zero and the held body is the first body that is not anchored (-1: none).
  bool has_device = true;
  /// What a run through the control loop (`numen run`, Python run_scene, SceneRunner) needs
  /// and this scene left out, as the located errors load_scene() throws without
  /// SceneOverrides::caller_steps (a missing [trajectory], then a missing [device]); empty when
  /// it can run. require_runnable() throws the first.
  std::vector<InputError> run_missing;
  std::vector<AttachEvent> events;  ///< Sorted by time.
  /// Per net (model.nets order): its surface triangles (the viewer draws them).
  std::vector<NetTriangles> net_triangles;
  /// Per net (model.nets order): how it was made from its mesh.
  std::vector<NetLoad> net_loads;
  /// Set exactly when model.coupling_mode is kAdmittance (the loader requires both or neither).
  std::optional<AdmittanceScene> admittance;
  /// The simulated hand on the device (`[device.hand]`; hand.hpp): what holds the handle in
  /// closed loop and what an admittance device's force sensor measures.
  HandSettings hand;
  /// The impedance device's mechanics (`[device.plant]`): set, the emulated device moves
  /// under the drives' torques and the hand (closed loop, PlantMotion); unset, it replays the
  /// trajectory whatever the torques. torque_phase_s is compute_phase_s.
  std::optional<DevicePlantSettings> plant;
  /// Device 0's hand's sight (`[device.trajectory.servo]` and its segments' `servo_target`;
  /// hand_servo.hpp): unset, the hand follows its script blind.
  std::optional<HandServoSpec> servo;
  /// The OpenIGTLink tracker (`[device.igtl]`, pose trackers only): the device `--bus igtl`
  /// reads; unset, `--bus igtl` is refused.
  std::optional<IgtlTrackerScene> igtl;
  /// The passivity lint of the plant against the feedback coupling (passivity_lint.hpp; empty
  /// in replay). A failing row is also a warning.
  std::vector<PassivityLintRow> passivity_lint;
  /// Set by a [multirate] table: the god-object runs at dt against an intermediate contact
  /// model the scene loop refreshes every scene_dt (the run harness, SceneRunner).
  std::optional<MultirateScene> multirate;
  /// Default run length (s): `duration`, else the trajectory's; 0 without either.
  double duration_s = 0.0;
  std::vector<std::string> warnings;  ///< Non-fatal remarks of the loader.
  /// How the trocar point was placed (for the summary), empty if not a trocar.
  std::string trocar_note;
  /// Devices 1 .. N−1 of a `[[device]]` array, in file order; empty for one device (`[device]`
  /// or a `[[device]]` of one entry). Device 0 is the fields above. Device i's Eq. 8 gains
  /// (`[device.feedback]`) are model.extra_feedback[i − 1] (core::feedback_gains()).
  std::vector<SceneDevice> extra_devices;
  /// The scene's `[task]`, if it has one.
  std::optional<SceneTask> task;
  /// Per needle (model.needles order): its marks (none unless the scene gives them).
  std::vector<NeedleMarks> needle_marks;
};

/// The device that turns the jaws of grasper `grasper` of `scene` (model.grasps): the device
/// whose binding prescribes a jaw's joint or links a jaw's body, as an index (0: Scene::device,
/// i: extra_devices[i − 1]); -1 when none does.
int grasper_device(const Scene& scene, int grasper) noexcept;

/// The number of devices of `scene`: 1 + scene.extra_devices.size().
inline std::size_t num_devices(const Scene& scene) noexcept { return 1 + scene.extra_devices.size(); }

/// Changes a caller may impose on a scene at load time (command line).
struct SceneOverrides {
  /// Replaces the scene's coupling (`numen run --coupling`): god-object, first-order or direct
  /// for an impedance scene; an admittance scene's coupling cannot be changed, nor another
  /// scene's made admittance (InputError, key "--coupling").
  std::optional<core::CouplingMode> coupling;
  /// Runs the device in replay (`numen run --replay`): the scene's [device.plant] is read and
  /// checked, then dropped; the encoders read the trajectory whatever the torques.
  bool replay = false;
  /// The passivity lint's findings are errors (`--strict`): InputError at [device.plant]
  /// damping instead of a warning (passivity_lint.hpp).
  bool strict = false;
  /// The scene is loaded to be stepped by the caller (the Python module's load_scene, a
  /// program of one's own setting the targets and calling core::step), not run through the
  /// control loop: [trajectory] and [device] may be left out (Scene::has_trajectory,
  /// Scene::has_device; Scene::run_missing holds the errors a run would raise).
  bool caller_steps = false;
};

/// Loads and compiles `path`. Throws InputError.
Scene load_scene(const std::string& path, const SceneOverrides& overrides = {});

/// Throws the first of scene.run_missing (the located error of a missing [trajectory] or
/// [device], which a run through the control loop needs); returns when there is none.
void require_runnable(const Scene& scene);

/// The shipped default scene: share/numen/scenes/default.toml of the installed prefix the
/// running executable belongs to, else sim/scenes/default.toml of the source tree
/// (shipped_data_dir(), shipped_files.hpp).
std::string default_scene_path();

/// "god-object", "first-order", "direct" → mode; throws InputError (key
/// "coupling") otherwise.
core::CouplingMode parse_coupling_mode(const std::string& name);
/// Name of a coupling mode as used in scene files.
const char* to_string(core::CouplingMode mode) noexcept;
/// Name of an integrator as used in scene files.
const char* to_string(core::Integrator integrator) noexcept;

}  // namespace numen::sim
