/// @file thread_summary.cpp
/// The suture threads of a run in its summary (thread_summary.hpp).

#include "numen/sim/run/thread_summary.hpp"

#include <algorithm>
#include <iomanip>
#include <sstream>

#include "numen/core/thread.hpp"
#include "numen/sim/run/run_summary.hpp"

namespace numen::sim {

void accumulate_thread_figures(const core::Data& data, RunSummary& s) noexcept {
  bool unconverged = false;
  for (const core::ThreadState& t : data.threads) {
    unconverged = unconverged || !t.output.converged;
    if (t.output.max_tension > s.thread_tension_max_n || s.thread_tension_max_s < 0.0) {
      s.thread_tension_max_n = t.output.max_tension;  // (≥ 0: the first step's is at least the 0 it starts at)
      s.thread_tension_max_s = data.time;
    }
    s.thread_stretch_max = std::max(s.thread_stretch_max, t.output.max_stretch);
    if (t.output.broke) {
      if (s.thread_breaks == 0) s.thread_first_break_s = data.time;
      ++s.thread_breaks;
    }
  }
  if (unconverged) ++s.thread_newton_not_converged_steps;
}

void summarize_threads(const core::Model& model, const core::Data& data, RunSummary& s) {
  s.threads = !model.threads.empty();
  for (std::size_t i = 0; i < model.threads.size() && i < data.threads.size(); ++i) {
    const core::ThreadState& st = data.threads[i];
    s.thread_eyelets_taken += st.eyelets_taken;
    s.thread_eyelets_let_go += st.eyelets_let_go;
    s.thread_eyelets_dropped += st.eyelets_dropped;
    if (st.eyelets_dropped > 0) {
      const core::ThreadModel& t = model.threads[i];
      s.warnings.push_back("thread '" + (t.name.empty() ? std::to_string(i) : t.name) + "' did not follow its needle through " +
                           std::to_string(st.eyelets_dropped) + " puncture point(s): all its " +
                           std::to_string(core::kMaxThreadEyelets) + " eyelets were taken");
    }
    const int segment = st.broken_segment;
    if (segment < 0) continue;
    const core::ThreadModel& t = model.threads[i];
    std::ostringstream os;
    os << "thread '" << (t.name.empty() ? std::to_string(i) : t.name) << "' broke at segment "
       << segment << " (strain past its break_strain " << t.break_strain << "; the run's first break at "
       << std::fixed << std::setprecision(3) << s.thread_first_break_s << " s)";
    s.warnings.push_back(os.str());
  }
}

}  // namespace numen::sim
