/// @file numen_peer.cpp
/// `numen_peer`: numen and MuJoCo side by side in one run (issue 6, docs/peer.md). Builds the
/// three comparison scenes, runs numen (core::step) and MuJoCo (mocap weld; PD through
/// xfrc_applied) on the same recorded device inputs, and prints the table (and a CSV).
///
///   ./build/numen_peer                         # full scenes: wall 3 s, construction 9 s,
///   instrument 30 s
///   ./build/numen_peer --duration 1 --csv peer.csv
///   ./build/numen_peer --scene wall --print-mjcf   # the translated MJCF of a scene

#include <mujoco/mujoco.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <fstream>
#include <iostream>

#include "mjcf_translation.hpp"
#include "peer_run.hpp"
#include "peer_scene.hpp"
#include "peer_table.hpp"

int main(int argc, char** argv) {
  // MuJoCo's warnings (e.g. a diverged state) go to stderr, not to MUJOCO_LOG.TXT in the
  // working directory.
  mju_user_warning = [](const char* msg) { std::fprintf(stderr, "MuJoCo warning: %s\n", msg); };
  CLI::App app{"numen and MuJoCo side by side: per-step time, penetration, free-space tracking"};
  double duration = -1.0;
  std::string csv, only;
  bool print_mjcf = false;
  app.add_option("--duration", duration,
                 "Simulated seconds per scene (default: each scene's full length)")
      ->check(CLI::PositiveNumber);
  app.add_option("--csv", csv, "Also write the rows to this CSV file");
  app.add_option("--scene", only, "Only this scene")
      ->check(CLI::IsMember({"wall", "construction", "instrument"}));
  app.add_flag("--print-mjcf", print_mjcf,
               "Print the MJCF translation of the scene(s) (mocap weld) and exit");
  CLI11_PARSE(app, argc, argv);

  try {
    std::vector<numen::peer::PeerScene> scenes;
    if (only.empty() || only == "wall") scenes.push_back(numen::peer::make_wall_scene(duration));
    if (only.empty() || only == "construction")
      scenes.push_back(numen::peer::load_recorded_scene("construction",
                                                        "sim/scenes/construction.toml", duration));
    if (only.empty() || only == "instrument")
      scenes.push_back(
          numen::peer::load_recorded_scene("instrument", "sim/scenes/lattice.toml", duration));
    if (print_mjcf) {
      for (const auto& s : scenes)
        std::cout << numen::peer::translate_to_mjcf(s.model, numen::peer::Drive::kMocapWeld,
                                                    numen::peer::held_bodies(s.inputs))
                         .xml;
      return 0;
    }
    std::cerr << "MuJoCo " << mj_versionString() << "; scenes:";
    for (const auto& s : scenes) std::cerr << " " << s.name << " (" << s.inputs.size() << " steps)";
    std::cerr << "\n";
    const auto rows = numen::peer::run_comparison(scenes, [](const numen::peer::PeerRow& r) {
      std::fprintf(stderr, "  done: %s %s / %s\n", r.scene.c_str(), r.engine.c_str(),
                   r.variant.c_str());
    });
    std::cout << numen::peer::format_table(rows);
    for (const auto& s : scenes) {
      const auto tr = numen::peer::translate_to_mjcf(s.model, numen::peer::Drive::kMocapWeld,
                                                     numen::peer::held_bodies(s.inputs));
      std::cout << "\n" << s.name << ": " << s.description << "\n";
      for (const auto& d : tr.differences) std::cout << "  - " << d << "\n";
    }
    if (!csv.empty()) {
      std::ofstream f(csv);
      f << numen::peer::format_csv(rows);
      if (!f) {
        std::cerr << "numen_peer: cannot write " << csv << "\n";
        return 1;
      }
    }
  } catch (const std::exception& e) {
    std::cerr << "numen_peer: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
