/// @file figures_command.cpp
/// `numen figures`: the run figures table (docs/outputs.md, "Summary figures", holds its output);
/// `numen figures --all`: the names of every output (record_lists.hpp).

#include <iostream>

#include "commands.hpp"
#include "numen/sim/run/record_lists.hpp"
#include "numen/sim/run/run_figures.hpp"

namespace numen::app {

FiguresCommand::FiguresCommand(CLI::App& parent)
    : cli_(parent.add_subcommand(
          "figures", "Print the figures of a run's summary (name, unit, meaning) as Markdown")) {
  cli_->add_flag("--all", all_,
                 "Also print the trace columns and the names every output writes (summary, "
                 "traces, study rows), from their declarations");
}

int FiguresCommand::execute() const {
  std::cout << (all_ ? sim::format_record_lists_markdown() : sim::format_run_figures_markdown());
  return 0;
}

}  // namespace numen::app
