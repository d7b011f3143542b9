/// @file soft_peer_run.cpp
/// The presses of both engines and their report (soft_peer_run.hpp).

#include "soft_peer_run.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

#include "numen/core/step.hpp"
#include "scene/net_tetrahedralize.hpp"
#include "step_percentiles.hpp"

namespace numen::soft_peer {

namespace {

using test::organ::IndentationSample;

std::int64_t now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

/// One engine's press: per-step times, the force per step, the sample every `every` steps.
struct Press {
  std::vector<std::int64_t> ns;
  std::vector<IndentationSample> curve;  // as indentation_curve(): one sample per `every` steps
  double window = 0.0;
  int every = 1;
  int contacts_max = 0;
  bool finite = true;

  void add(long k, double s, double touch, double force) {
    finite = finite && std::isfinite(force);
    window += force;
    if (k % every == 0) {
      curve.push_back({s - touch, window / (k == 0 ? 1 : every)});
      window = 0.0;
    }
  }
};

/// The path's step count at `dt` with samples every `every` steps (indentation_curve()'s).
long path_steps(const PressScene& sc, double touch, double dt, int every) {
  return every * static_cast<long>(std::ceil((touch + sc.depth) / sc.speed / (every * dt) - 1e-9));
}

core::Model numen_model(const PressScene& sc, double dt) {
  if (sc.tissue)
    return test::organ::tissue_model(sc.volume, *sc.tissue, dt, core::CouplingMode::kDirect,
                                     sc.tool_radius, sc.from);
  return test::organ::organ_model(sc.mesh, sc.params, dt, core::CouplingMode::kDirect,
                                  sc.tool_radius, sc.from);
}

/// numen's step k on the path: the imposed tool at from + s·dir (s = speed·k·dt), moving at
/// speed; the step timed, its force sampled into `p`.
void numen_path_step(const core::Model& m, core::Data& d, const PressScene& sc, long k, double touch,
                     Press& p) {
  const double s = sc.speed * static_cast<double>(k) * m.dt;
  d.target.position = sc.from + s * sc.dir;
  d.target.orientation = core::Quat::Identity();
  d.target_twist.linear = sc.speed * sc.dir;
  d.target_twist.angular.setZero();
  const std::int64_t t0 = now_ns();
  core::step(m, d);
  const std::int64_t t1 = now_ns();
  p.ns.push_back(t1 - t0);
  p.finite = p.finite && d.status == core::kStepOk;
  p.contacts_max = std::max(p.contacts_max, d.num_node_contacts);
  p.add(k, s, touch, test::organ::organ_force_on_tool(d, sc.dir));
}

double force_near(const std::vector<IndentationSample>& means, double depth) {
  double best = 0.0, dist = 1e9;
  for (const auto& m : means)
    if (std::abs(m.depth - depth) < dist) dist = std::abs(m.depth - depth), best = m.force;
  return best;
}

SoftPeerRow make_row(const PressScene& sc, const char* engine, std::string variant, int nodes,
                     int springs, double dt, Press& p) {
  SoftPeerRow r;
  r.scene = sc.name;
  r.engine = engine;
  r.variant = std::move(variant);
  r.nodes = nodes;
  r.springs = springs;
  r.dt = dt;
  r.steps = static_cast<std::int64_t>(p.ns.size());
  test::percentiles_us(p.ns, r.step_median_us, r.step_p99_us);
  const auto means = test::organ::block_means(p.curve, 5);
  r.force_2mm = force_near(means, 0.002);
  r.force_4mm = force_near(means, 0.004);
  r.force_6mm = force_near(means, 0.006);
  for (const auto& m : means) r.peak_force = std::max(r.peak_force, m.force);
  r.contacts_max = p.contacts_max;
  r.finite = p.finite;
  return r;
}

std::string fixed(double v, int digits) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

}  // namespace

PressScene organ_scene() {
  PressScene sc;
  sc.name = "organ";
  sc.mesh = test::organ::shipped_organ_mesh();
  if (sc.mesh.num_vertices() != 1002)
    throw std::runtime_error("sim/data/organ_lobe.obj: expected 1002 vertices, read " +
                             std::to_string(sc.mesh.num_vertices()));
  sc.description =
      "the shipped organ (sim/data/organ_lobe.obj), 2.5 mm sphere from -z onto its convex face "
      "at 20 mm/s, 6 mm past the first touch (docs/organs.md \"Force against indentation\")";
  return sc;
}

PressScene ellipsoid_scene() {
  PressScene sc;
  sc.name = "ellipsoid";
  sc.mesh = core::make_icosphere(1.0, 4);
  for (auto& v : sc.mesh.vertices) v = core::Vec3(0.04 * v.x(), 0.03 * v.y(), 0.02 * v.z());
  sc.description =
      "an ellipsoid 80 x 60 x 40 mm (icosphere of 4 subdivisions, scaled), the organ's constants, "
      "the same sphere and speed from -z onto its pole, 6 mm past the first touch";
  return sc;
}

PressScene material_scene(PressScene sc) {
  core::NetMaterial tissue;
  tissue.youngs_modulus = 100e3;
  tissue.poisson_ratio = 0.45;
  tissue.density = 1000.0;
  tissue.rayleigh_stiffness = 1e-3;
  tissue.support_length = 0.02;
  sc.tissue = tissue;
  const std::string why =
      sim::tetrahedralize_net(sc.mesh, sim::kInteriorSpacingEdges * sim::mean_edge_length(sc.mesh), sc.volume);
  if (!why.empty()) throw std::runtime_error(sc.name + ": " + why);
  sc.name += "-material";
  sc.description = "the same, given its material (E 100 kPa, nu 0.45, rho 1000 kg/m3, beta 1 ms, "
                   "support 20 mm; docs/tissue.md), " + std::to_string(sc.volume.interior.size()) +
                   " interior nodes, " + std::to_string(sc.volume.tetrahedra.size()) + " tetrahedra";
  return sc;
}

CurveError curve_error(const std::vector<IndentationSample>& means,
                       const std::vector<IndentationSample>& reference_means) {
  if (means.size() != reference_means.size())
    throw std::invalid_argument("curve_error: curves of " + std::to_string(means.size()) + " and " +
                                std::to_string(reference_means.size()) + " means");
  CurveError e;
  double sq = 0.0;
  for (std::size_t i = 0; i < means.size(); ++i) {
    const double d = std::abs(means[i].force - reference_means[i].force);
    sq += d * d;
    if (d > e.max_abs) e.max_abs = d, e.at_depth = reference_means[i].depth;
  }
  e.rms = means.empty() ? 0.0 : std::sqrt(sq / static_cast<double>(means.size()));
  return e;
}

std::vector<SoftPeerRow> run_scene(const PressScene& sc, const BulletOptions& options,
                                   std::vector<CurveLine>* curves) {
  const core::Model coarse = numen_model(sc, sc.dt);
  const double touch = test::organ::first_touch(coarse, sc.from, sc.dir, sc.tool_radius);
  if (!std::isfinite(touch)) throw std::runtime_error(sc.name + ": the tool's path misses the organ");
  const int springs = static_cast<int>(coarse.net_springs.size());

  // numen and Bullet at dt, one step of each in turn.
  BulletOrgan bullet(coarse, options);
  core::Data d = core::make_data(coarse);
  Press pn, pb;
  const long steps = path_steps(sc, touch, sc.dt, 1);
  for (long k = 0; k <= steps; ++k) {
    numen_path_step(coarse, d, sc, k, touch, pn);
    const double s = sc.speed * static_cast<double>(k) * sc.dt;
    bullet.set_tool(sc.from + s * sc.dir, sc.speed * sc.dir);
    const std::int64_t t0 = now_ns();
    bullet.step();
    const std::int64_t t1 = now_ns();
    pb.ns.push_back(t1 - t0);
    pb.contacts_max = std::max(pb.contacts_max, bullet.num_contacts());
    pb.add(k, s, touch, bullet.force_on_organ().dot(sc.dir));
  }
  // numen's reference at dt/10, sampled over the same periods.
  const core::Model fine = numen_model(sc, sc.dt / 10);
  core::Data df = core::make_data(fine);
  Press pf;
  pf.every = 10;
  const long fine_steps = path_steps(sc, touch, fine.dt, 10);
  for (long k = 0; k <= fine_steps; ++k) numen_path_step(fine, df, sc, k, touch, pf);

  const BulletOrganStats& bs = bullet.stats();
  std::vector<SoftPeerRow> rows;
  const std::string numen_variant =
      std::string(sc.tissue ? "material net, " : "") + "linearly implicit Euler, CG 3e-4";
  rows.push_back(make_row(sc, "numen", numen_variant, coarse.num_nodes(), springs, sc.dt, pn));
  rows.push_back(make_row(sc, "bullet",
                          "btSoftBody, " + std::to_string(options.position_iterations) +
                              " position iterations",
                          bs.nodes, bs.structural_links + bs.bending_links, sc.dt, pb));
  rows.push_back(make_row(sc, "numen", numen_variant + " (reference)",
                          fine.num_nodes(), springs, fine.dt, pf));
  const auto ref = test::organ::block_means(pf.curve, 5);
  const std::vector<IndentationSample>* curve_of[] = {&pn.curve, &pb.curve, &pf.curve};
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const auto means = test::organ::block_means(*curve_of[i], 5);
    if (i < 2) {
      const CurveError e = curve_error(means, ref);
      rows[i].force_error_max = e.max_abs;
      rows[i].force_error_at_mm = 1e3 * e.at_depth;
      rows[i].force_error_rms = e.rms;
    }
    if (rows[i].step_median_us > 0.0)
      rows[i].ratio_numen_over_this = rows[0].step_median_us / rows[i].step_median_us;
    if (curves) curves->push_back({sc.name, rows[i].engine, rows[i].dt, means});
  }
  return rows;
}

std::string format_table(const std::vector<SoftPeerRow>& rows) {
  std::ostringstream os;
  os << "| scene | engine / variant | nodes | springs (numen) / links (Bullet) | dt ms | median µs/step | "
        "p99 µs | ratio numen/this | force at 2 / 4 / 6 mm, N | peak N | force error vs numen 0.1 ms: "
        "max N (at mm) / rms N |\n";
  os << "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n";
  for (const SoftPeerRow& r : rows) {
    const bool reference = r.engine == "numen" && r.dt < 0.9e-3;
    os << "| " << r.scene << " | " << r.engine << " / " << r.variant << " | " << r.nodes << " | "
       << r.springs << " | " << fixed(1e3 * r.dt, 1) << " | " << fixed(r.step_median_us, 1) << " | "
       << fixed(r.step_p99_us, 1) << " | "
       << (r.engine == "bullet" ? fixed(r.ratio_numen_over_this, 3) : std::string("—")) << " | "
       << fixed(r.force_2mm, 3) << " / " << fixed(r.force_4mm, 3) << " / " << fixed(r.force_6mm, 3)
       << " | " << fixed(r.peak_force, 3) << " | "
       << (reference ? std::string("(reference)")
                     : fixed(r.force_error_max, 3) + " (" + fixed(r.force_error_at_mm, 2) + ") / " +
                           fixed(r.force_error_rms, 3))
       << (r.finite ? "" : " NOT FINITE") << " |\n";
  }
  return os.str();
}

std::string format_csv(const std::vector<SoftPeerRow>& rows) {
  std::ostringstream os;
  os << "scene,engine,variant,nodes,springs,dt_s,steps,step_median_us,step_p99_us,"
        "ratio_numen_over_this,force_2mm_n,force_4mm_n,force_6mm_n,peak_force_n,force_error_max_n,"
        "force_error_at_mm,force_error_rms_n,contacts_max,finite\n";
  for (const SoftPeerRow& r : rows)
    os << r.scene << "," << r.engine << ",\"" << r.variant << "\"," << r.nodes << "," << r.springs
       << "," << r.dt << "," << r.steps << "," << fixed(r.step_median_us, 3) << ","
       << fixed(r.step_p99_us, 3) << "," << fixed(r.ratio_numen_over_this, 4) << ","
       << fixed(r.force_2mm, 6) << "," << fixed(r.force_4mm, 6) << "," << fixed(r.force_6mm, 6)
       << "," << fixed(r.peak_force, 6) << "," << fixed(r.force_error_max, 6) << ","
       << fixed(r.force_error_at_mm, 3) << "," << fixed(r.force_error_rms, 6) << ","
       << r.contacts_max << "," << (r.finite ? 1 : 0) << "\n";
  return os.str();
}

std::string format_curves_csv(const std::vector<CurveLine>& curves) {
  std::ostringstream os;
  os << "scene,engine,dt_s,depth_mm,force_n\n";
  for (const CurveLine& c : curves)
    for (const auto& m : c.means)
      os << c.scene << "," << c.engine << "," << c.dt << "," << fixed(1e3 * m.depth, 4) << ","
         << fixed(m.force, 6) << "\n";
  return os.str();
}

}  // namespace numen::soft_peer
