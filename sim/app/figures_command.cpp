/// @file figures_command.cpp
/// `numen figures`: the run figures table (docs/scenes.md, "Summary figures", holds its output).

#include <iostream>

#include "commands.hpp"
#include "numen/sim/run_figures.hpp"

namespace numen::app {

FiguresCommand::FiguresCommand(CLI::App& parent)
    : cli_(parent.add_subcommand(
          "figures", "Print the figures of a run's summary (name, unit, meaning) as Markdown")) {}

int FiguresCommand::execute() const {
  std::cout << sim::format_run_figures_markdown();
  return 0;
}

}  // namespace numen::app
