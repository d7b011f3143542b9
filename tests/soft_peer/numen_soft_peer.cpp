/// @file numen_soft_peer.cpp
/// `numen_soft_peer`: numen's organ and the same mesh as Bullet's soft body, pressed by the same
/// sphere along the same path in one process (docs/soft_peer.md): step time of each engine at
/// the same node count and dt, the force against indentation of each against numen's dt/10
/// reference; a Markdown table on stdout, CSVs on request.
///
///   ./build/numen_soft_peer                          # organ (1002 nodes) and ellipsoid (2562),
///                                                    # then both given their material
///   ./build/numen_soft_peer --scene organ --depth 1 --csv soft_peer.csv --curves curves.csv

#include <LinearMath/btScalar.h>

#include <CLI/CLI.hpp>
#include <fstream>
#include <iostream>

#include "soft_peer_run.hpp"

namespace {

bool write_file(const std::string& path, const std::string& text) {
  std::ofstream f(path);
  f << text;
  if (!f) std::cerr << "numen_soft_peer: cannot write " << path << "\n";
  return static_cast<bool>(f);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"numen and Bullet's soft body side by side: step time and force against indentation"};
  std::string csv, curves_csv, only;
  double depth_mm = 6.0;
  numen::soft_peer::BulletOptions options;
  app.add_option("--scene", only, "Only this scene")
      ->check(CLI::IsMember({"organ", "ellipsoid", "organ-material", "ellipsoid-material"}));
  app.add_option("--depth", depth_mm, "How far past the first touch the press goes (mm)")
      ->check(CLI::Range(0.1, 10.0));
  app.add_option("--piterations", options.position_iterations,
                 "Bullet's position iterations (Bullet's default 1; the issue's 4)")
      ->check(CLI::Range(1, 100));
  app.add_option("--margin", options.margin, "Bullet soft body collision margin (m)")
      ->check(CLI::PositiveNumber);
  app.add_option("--csv", csv, "Also write the rows to this CSV file");
  app.add_option("--curves", curves_csv, "Also write the force curves (5 ms means) to this CSV file");
  CLI11_PARSE(app, argc, argv);

  try {
    std::vector<numen::soft_peer::PressScene> scenes;
    if (only.empty() || only == "organ") scenes.push_back(numen::soft_peer::organ_scene());
    if (only.empty() || only == "ellipsoid") scenes.push_back(numen::soft_peer::ellipsoid_scene());
    if (only.empty() || only == "organ-material")
      scenes.push_back(numen::soft_peer::material_scene(numen::soft_peer::organ_scene()));
    if (only.empty() || only == "ellipsoid-material")
      scenes.push_back(numen::soft_peer::material_scene(numen::soft_peer::ellipsoid_scene()));
    std::cerr << "Bullet " << btGetVersion() << " (" << (sizeof(btScalar) == 8 ? "double" : "float")
              << "), " << options.position_iterations << " position iterations\n";
    std::vector<numen::soft_peer::SoftPeerRow> rows;
    std::vector<numen::soft_peer::CurveLine> curves;
    for (auto& sc : scenes) {
      sc.depth = 1e-3 * depth_mm;
      const auto r = numen::soft_peer::run_scene(sc, options, &curves);
      rows.insert(rows.end(), r.begin(), r.end());
      std::cerr << "  done: " << sc.name << "\n";
    }
    std::cout << numen::soft_peer::format_table(rows);
    for (const auto& sc : scenes) std::cout << "\n" << sc.name << ": " << sc.description << "\n";
    if (!csv.empty() && !write_file(csv, numen::soft_peer::format_csv(rows))) return 1;
    if (!curves_csv.empty() && !write_file(curves_csv, numen::soft_peer::format_curves_csv(curves)))
      return 1;
    for (const auto& r : rows)
      if (!r.finite) {
        std::cerr << "numen_soft_peer: " << r.scene << " / " << r.engine << ": a step was not finite\n";
        return 1;
      }
  } catch (const std::exception& e) {
    std::cerr << "numen_soft_peer: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
