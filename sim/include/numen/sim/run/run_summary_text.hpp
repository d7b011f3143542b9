#pragma once
/// @file run_summary_text.hpp
/// The layout of the text summary of `numen run` (format_summary()): a list of segments whose
/// `{figure}` placeholders name figures of run_figures(), so the text can only print figures
/// of the table, and a test checks that every figure of the table is printed.

#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace numen::sim {

struct RunSummary;

/// When a segment of the text summary is printed, from one figure of run_figures().
struct RunSummaryCondition {
  /// How the figure is tested (FigureValue::set()).
  enum class Test : unsigned char {
    kAlways,  ///< No condition (figure empty).
    kSet,     ///< The figure is set: non-zero, true, non-empty.
    kUnset,   ///< The figure is not set.
    kLogBus,  ///< The (text) figure starts with "log:" (the --bus spec of a replayed log).
  };
  std::string_view figure;  ///< A figure name; empty with kAlways.
  Test test = Test::kAlways;
  /// Optional second figure, tested like `figure` and OR-ed with it; empty: none.
  std::string_view or_figure = {};
};

/// One piece of the text summary. `text` is printed when every condition holds; in it,
/// `{name}` is the value of figure `name`, formatted by kind (reals fixed with 3 decimals,
/// counts as integers, text as is) or by a spec after a colon: `{name:e2}` scientific with 2
/// decimals, `{name:ms}` the value × 1e3 with 3 decimals (s → ms), `{name:us1}` the value ×
/// 1e-3 with 1 decimal (ns → µs). With `each` (a text-list figure) the text is printed once
/// per element, `{*}` standing for the element, and `first` (when not empty) replaces `text`
/// for the first element.
struct RunSummarySegment {
  std::string_view text;
  RunSummaryCondition when = {};
  RunSummaryCondition and_when = {};
  RunSummaryCondition and_also = {};
  std::string_view each = {};
  std::string_view first = {};
};

/// The segments of the text summary, in print order.
std::span<const RunSummarySegment> run_summary_text_layout() noexcept;

/// format_summary(s); `written` (when not null) receives the names of the figures the text
/// holds: those of the placeholders printed and those of the conditions of the segments
/// printed (a flag shows as its wording, e.g. "nan detected: no"). Throws std::logic_error
/// for a placeholder or condition that names no figure (a layout error).
std::string format_summary_text(const RunSummary& s, std::vector<std::string_view>* written);

}  // namespace numen::sim
