/// @file igtl_replay_command.cpp
/// `numen igtl-replay`: a scene's trajectory played as an OpenIGTLink tracker server
/// (docs/openigtlink.md).

#include <iostream>

#include "commands.hpp"
#include "numen/sim/device/igtl_replay.hpp"
#include "numen/sim/scene/scene.hpp"
#include "signals.hpp"

namespace numen::app {

IgtlReplayCommand::IgtlReplayCommand(CLI::App& parent)
    : cli_(parent.add_subcommand(
          "igtl-replay", "Play a scene's trajectory as an OpenIGTLink tracker server (the TRANSFORMs "
                         "of its [device.igtl] tool), for numen run --bus igtl")) {
  cli_->add_option("scene", scene_, "Scene file (TOML) with a [device.igtl]");
  cli_->add_option("--host", host_,
                   "Address to listen on: IPv4, IPv6 (without brackets) or localhost (default "
                   "127.0.0.1)");
  cli_->add_option("--port", port_, "TCP port (default 18944; 0: any free port, printed)")
      ->check(count_check(0, 65535));
  cli_->add_option("--rate", rate_, "Messages per second (default: 1 / the scene's dt)")
      ->check(number_check(0.0, 1e6, true));
  cli_->add_option("--duration", duration_, "Seconds of trajectory (default: the scene's)")
      ->check(seconds_check(0.0, 1e6, false));
  cli_->add_option("--accept-timeout", accept_timeout_, "Seconds to wait for a client (default 30)")
      ->check(seconds_check(0.0, 1e6, true));
  cli_->add_option("--message", message_,
                   "The pose message sent: transform (default, as PLUS), position (POSITION, "
                   "position and quaternion) or qtrans")
      ->check(CLI::IsMember({"transform", "position", "qtrans"}));
  cli_->add_option("--stall", stall_,
                   "Seconds the tracker goes silent (a hidden marker): the poses of that "
                   "stretch are not sent, and the server waits as long (default 0: none)")
      ->check(seconds_check(0.0, 1e6, false));
  cli_->add_option("--stall-at", stall_at_, "Trajectory time the --stall begins, s (default 0)")
      ->check(seconds_check(0.0, 1e6, false));
  cli_->add_flag("--realtime", realtime_,
                 "Send at the trajectory's pace (a live tracker) instead of as fast as the client reads");
}

int IgtlReplayCommand::execute() const {
  const std::string path = scene_.empty() ? sim::default_scene_path() : scene_;
  const sim::Scene scene = sim::load_scene(path, sim::SceneOverrides{});
  sim::IgtlReplaySettings settings;
  settings.host = host_;
  settings.port = static_cast<std::uint16_t>(port_);
  settings.rate_hz = rate_;
  settings.duration_s = duration_;
  settings.paced = realtime_;
  settings.stall_at_s = stall_at_;
  settings.stall_s = stall_;
  settings.accept_timeout_s = accept_timeout_;
  settings.message = message_ == "position" ? sim::IgtlReplayMessage::kPosition
                     : message_ == "qtrans" ? sim::IgtlReplayMessage::kQtrans
                                            : sim::IgtlReplayMessage::kTransform;
  sim::IgtlReplayServer server(scene, settings);
  std::cerr << "numen igtl-replay: listening on " << host_ << ":" << server.port() << "\n";
  loading_done();
  const sim::IgtlReplayResult r = server.serve(&stop_flag());
  const std::string type = message_ == "qtrans"     ? "QTRANS"
                           : message_ == "position" ? "POSITION"
                                                    : "TRANSFORM";
  std::cerr << "numen igtl-replay: " << r.messages_sent << " " << type << "s sent"
            << (r.client_connected ? "" : " (no client connected)")
            << (r.client_gone ? " (the client left early)" : "") << "\n";
  return r.client_connected && !r.client_gone ? 0 : 1;
}

}  // namespace numen::app
