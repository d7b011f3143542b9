#pragma once
/// @file run_figures.hpp
/// The one list of a run's figures (RunSummary): name, unit, description and accessor of each.
/// The JSON summary (`numen run --json`), the text summary (run_summary_text.hpp) and the
/// docs table (docs/outputs.md, "Summary figures") are written from it; a figure added here
/// appears in all of them, and a test checks that none is missing from any. The accessors
/// never allocate, so a periodic state stream can read the same table.

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace numen::sim {

struct RunSummary;

/// What a figure's value is.
enum class FigureKind : std::uint8_t {
  kReal,      ///< A double (JSON number; null when not finite).
  kCount,     ///< A signed integer (periods, frames, indices; -1 often means "never").
  kFlag,      ///< A boolean.
  kText,      ///< A string (names, states, notes).
  kTextList,  ///< A list of strings (warnings, drive states, reasons).
};

/// The value of one figure of one summary. Only the member of `kind` is meaningful; `text` and
/// `list` point into the summary they were read from.
struct FigureValue {
  FigureKind kind = FigureKind::kReal;
  double real = 0.0;
  std::int64_t count = 0;
  bool flag = false;
  std::string_view text;
  const std::vector<std::string>* list = nullptr;

  /// True when the value is "set": non-zero number, true flag, non-empty text or list. The
  /// text summary prints some lines only for set figures (RunSummaryCondition).
  bool set() const noexcept;
};

/// One figure of a run's summary.
struct RunFigure {
  /// JSON path, parts separated by '.' ("loop.step_ns.p99" is {"loop":{"step_ns":{"p99":…}}});
  /// the same name is used by the text summary's placeholders and the docs table.
  std::string_view name;
  /// SI unit or the unit its name ends in ("mm", "us", "ns", "N·m"); "" for counts, flags and
  /// text; "1" for dimensionless ratios.
  std::string_view unit;
  std::string_view description;  ///< One line: what it measures.
  FigureKind kind;
  /// Reads the figure from a summary (never allocates or throws).
  FigureValue (*get)(const RunSummary&) noexcept;
  /// Whether the figure belongs in this summary's JSON; nullptr: always. (The admittance
  /// figures are only written for admittance runs.)
  bool (*present)(const RunSummary&) noexcept = nullptr;
};

/// Every figure of a run, in the order of the JSON object.
std::span<const RunFigure> run_figures() noexcept;

/// The figure called `name`, or nullptr.
const RunFigure* find_run_figure(std::string_view name) noexcept;

/// The table as Markdown (`numen figures`; docs/outputs.md holds it verbatim, tested): a
/// header "| figure | unit | what it measures |", a rule and one row per figure, '|' in
/// descriptions escaped.
std::string format_run_figures_markdown();

}  // namespace numen::sim
