/// @file view_command.cpp
/// `numen view FILE.nmv`: serves a view recording to the browser (docs/viewer.md "Replay"):
/// the page, the scene message, the frame index, and the frames the page asks for. Runs until
/// SIGINT / SIGTERM / SIGHUP.

#include <chrono>
#include <filesystem>
#include <iostream>
#include <thread>

#include "commands.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/view/view_recording.hpp"
#include "numen/sim/input/shipped_files.hpp"
#include "numen/sim/view/view_series.hpp"
#include "numen/sim/view/view_server.hpp"
#include "signals.hpp"

namespace numen::app {

std::string viewer_page_dir() { return sim::shipped_viewer_dir(NUMEN_VIEWER_DIR).string(); }

void warn_if_exposed(const std::string& host, std::ostream& err, const char* what) {
  if (!sim::ViewServer::is_loopback_address(host))
    err << "numen: warning: " << what << " listens on " << host
        << ", reachable from the network; anyone who can reach it sees the run (read-only)\n";
}

std::string viewer_overload(const sim::ViewServerCounters& c, std::size_t max_http_connections) {
  std::string out;
  if (c.connections_shed > 0)
    out += ", " + std::to_string(c.connections_shed) + " HTTP connections shed (more than " +
           std::to_string(max_http_connections) + " open)";
  if (c.accept_failures > 0)
    out +=
        ", " + std::to_string(c.accept_failures) + " accepts failed (out of descriptors or memory)";
  return out;
}

ViewCommand::ViewCommand(CLI::App& parent)
    : cli_(parent.add_subcommand("view", "Serve a view recording (--record-view) to the browser")) {
  cli_->add_option("file", file_, "View recording written by `numen run --record-view FILE`")
      ->required();
  cli_->add_option("--port", port_, "TCP port (default 8080; 0: any free port, printed)");
  cli_->add_option("--host", host_,
                   "Address to listen on (default 127.0.0.1; any other is reachable from the "
                   "network and is warned about)");
  cli_->add_option("--page", page_dir_, "Folder of the viewer page (default: the build's)");
}

int ViewCommand::execute() const {
  if (!sim::ViewServer::is_address(host_))
    throw sim::InputError("", 0, 0, "--host",
                          "'" + host_ + "' is not an IP address (e.g. 127.0.0.1, 0.0.0.0, ::1) or "
                          "localhost; host names are not resolved");
  if (!page_dir_.empty() && !std::filesystem::is_regular_file(std::filesystem::path(page_dir_) / "index.html"))
    throw sim::InputError("", 0, 0, "--page",
                          page_dir_ + ": no index.html there (the folder of the viewer page)");
  const sim::ViewRecordingReader reader(file_);
  sim::ViewRecordingSource source(reader);
  sim::ViewServerSettings settings;
  settings.host = host_;
  settings.port = port_;
  settings.static_dir = page_dir_.empty() ? viewer_page_dir() : page_dir_;
  warn_if_exposed(host_, std::cerr);
  // The plots' series over the whole file (decimated, docs/viewer.md "Replay").
  sim::ViewServer server(settings, reader.scene_message(), source, sim::view_replay_series(source));
  loading_done();
  server.start();
  const double seconds =
      reader.size() > 0 ? static_cast<double>(reader.time_ns(reader.size() - 1) - reader.time_ns(0)) * 1e-9
                        : 0.0;
  std::cout << "numen view: " << file_ << ": " << reader.size() << " frames, " << seconds
            << " s; open " << server.url() << " (Ctrl-C ends)" << std::endl;
  while (!stop_flag().load()) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  server.stop();
  const sim::ViewServerCounters c = server.counters();
  std::cout << "numen view: " << c.clients_total << " viewers, " << c.requests << " frames served, "
            << c.closed_bad_input << " connections closed for bad input"
            << viewer_overload(c, settings.max_http_connections) << std::endl;
  return 0;
}

}  // namespace numen::app
