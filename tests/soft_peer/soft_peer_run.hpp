#pragma once
/// @file soft_peer_run.hpp
/// numen and Bullet's soft body pressed by the same sphere along the same path, in one process
/// (docs/soft_peer.md): the scenes, the runs, the rows of the comparison and their table/CSV.
///
/// A press: the organ model of organ_indentation.hpp (organ_model(), kDirect: the tool is
/// imposed) and its translation into Bullet (bullet_organ.hpp); the tool's centre moves from
/// `from` along `dir` at `speed`, step k at from + speed·k·dt·dir, until it is `depth` past its
/// first touch of numen's rest surface (first_touch(): the depth axis of both engines). numen
/// and Bullet step at dt = 1 ms in the same loop, one step of each in turn, each step timed
/// alone (std::chrono::steady_clock, CLOCK_MONOTONIC); then numen alone at dt/10, the reference
/// both force curves are compared with (over 5 ms means, as docs/organs.md "Force against
/// indentation").

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "bullet_organ.hpp"
#include "numen/core/net_material.hpp"
#include "organ_indentation.hpp"

namespace numen::soft_peer {

/// One press of a mesh by a sphere.
struct PressScene {
  std::string name;         ///< "organ" or "ellipsoid" (the table's first column).
  std::string description;  ///< One line for the report.
  core::TriangleMesh mesh;  ///< The organ's rest shape (m, the organ's frame = world).
  test::organ::OrganParams params;  ///< The net's constants per spring (when `tissue` is empty).
  /// The organ given by its material instead (docs/tissue.md): the net is `volume`, `mesh`
  /// filled with interior nodes (sim's tetrahedralize_net at its default interior spacing), its
  /// constants derived from this material (core::add_material_net()).
  std::optional<core::NetMaterial> tissue;
  core::TetrahedralMesh volume;  ///< The material net's nodes and tetrahedra (with `tissue`).
  double tool_radius = 0.0025;              ///< m
  /// Tool centre at step 0 (m, world): the indentation test's, 4 mm, −3 mm off the axis, 30 mm
  /// below the organ's centre.
  core::Vec3 from = core::Vec3(0.004, -0.003, -0.03);
  core::Vec3 dir = core::Vec3::UnitZ();     ///< Unit direction of the path.
  double speed = 0.02;                      ///< m/s
  double depth = 0.006;                     ///< m past the first touch where the press ends.
  double dt = 1e-3;                         ///< s, both engines; the reference at dt/10.
};

/// The shipped organ (sim/data/organ_lobe.obj, 1002 nodes, OrganParams), the 2.5 mm sphere from
/// −z onto its convex face at 20 mm/s, 6 mm deep: the indentation test of docs/organs.md.
PressScene organ_scene();

/// An ellipsoid of semi-axes 40 × 30 × 20 mm (the icosphere of 4 subdivisions, 2562 nodes,
/// scaled), the same constants, the same sphere from −z onto its pole at 20 mm/s, 6 mm deep.
PressScene ellipsoid_scene();

/// `sc` given its material: E = 100 kPa, ν = 0.45, ρ = 1000 kg/m³, β = 1 ms, ℓ = 20 mm (the
/// shipped organ's material, docs/tissue.md), its mesh filled with interior nodes at twice its
/// mean edge (sim::kInteriorSpacingEdges) and tetrahedralised; the name gains "-material".
/// Throws std::runtime_error when the mesh cannot be tetrahedralised (its message).
PressScene material_scene(PressScene sc);

/// One engine's row of the comparison.
struct SoftPeerRow {
  std::string scene;
  std::string engine;   ///< "numen" or "bullet".
  std::string variant;  ///< The step and the solver, in words.
  int nodes = 0;
  int springs = 0;      ///< numen: structural + bending springs; Bullet: links.
  double dt = 0.0;      ///< s
  std::int64_t steps = 0;
  double step_median_us = 0.0, step_p99_us = 0.0;
  /// numen's (dt = 1 ms) median over this row's (1 for numen's rows; the target: ≤ 0.25
  /// against Bullet).
  double ratio_numen_over_this = 1.0;
  double force_2mm = 0.0, force_4mm = 0.0, force_6mm = 0.0;  ///< N, 5 ms means nearest those depths.
  double peak_force = 0.0;      ///< N, the largest 5 ms mean.
  /// Against numen's dt/10 reference (0 for the reference itself), 5 ms means: largest |Δ| (N),
  /// the depth (mm) where it is, and the RMS of the differences over the press (N).
  double force_error_max = 0.0, force_error_at_mm = 0.0, force_error_rms = 0.0;
  int contacts_max = 0;         ///< Most tool contacts in one step (numen: node contacts).
  bool finite = true;           ///< Every force and, for numen, every step's status kStepOk.
};

/// One engine's force curve (5 ms means: depth m, force N) with its scene and engine.
struct CurveLine {
  std::string scene, engine;
  double dt = 0.0;
  std::vector<test::organ::IndentationSample> means;
};

/// The comparison of one scene: rows numen (dt), Bullet (dt), numen (dt/10, reference), with
/// ratios and force errors filled in; `curves`, if set, gets each row's 5 ms means.
std::vector<SoftPeerRow> run_scene(const PressScene& scene, const BulletOptions& options,
                                   std::vector<CurveLine>* curves = nullptr);

/// Differences of two curves' 5 ms means (same sample times; `reference` the dt/10 curve).
struct CurveError {
  double max_abs = 0.0;   ///< N
  double at_depth = 0.0;  ///< m, the depth of the largest difference
  double rms = 0.0;       ///< N
};
CurveError curve_error(const std::vector<test::organ::IndentationSample>& means,
                       const std::vector<test::organ::IndentationSample>& reference_means);

/// Markdown table: scene | engine / variant | nodes | springs or links | dt | median µs | p99 µs |
/// ratio numen/this | force at 2 / 4 / 6 mm | peak | force error max (at) / rms.
std::string format_table(const std::vector<SoftPeerRow>& rows);

/// CSV, one header line then one line per row: scene, engine, variant, nodes, springs, dt_s,
/// steps, step_median_us, step_p99_us, ratio_numen_over_this, force_2mm_n, force_4mm_n,
/// force_6mm_n, peak_force_n, force_error_max_n, force_error_at_mm, force_error_rms_n,
/// contacts_max, finite.
std::string format_csv(const std::vector<SoftPeerRow>& rows);

/// CSV of the curves: scene, engine, dt_s, depth_mm, force_n (one line per 5 ms mean).
std::string format_curves_csv(const std::vector<CurveLine>& curves);

}  // namespace numen::soft_peer
