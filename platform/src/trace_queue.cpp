/// @file trace_queue.cpp
/// Non-blocking per-period traces: CSV lines formatted on the consumer thread of an
/// hal::AsyncRecordWriter.

#include "numen/platform/trace_queue.hpp"

#include <pthread.h>
#include <sched.h>

#include <charconv>
#include <future>
#include <stdexcept>
#include <unordered_set>

namespace numen::platform {
namespace {

// Longest line: three integers (20 digits + sign) and kTraceMaxColumns doubles (to_chars
// shortest form: at most 24 characters), each with its separator, and the newline.
constexpr std::size_t kLineBufferSize = 3 * 22 + kTraceMaxColumns * 26 + 2;

/// Appends `sep` (unless '\0') and `v` at `p` (doubles in the shortest round-trip form);
/// false if it does not fit before `end`.
template <class T>
bool put(char*& p, char* end, T v, char sep) noexcept {
  if (sep != '\0') {
    if (p == end) return false;
    *p++ = sep;
  }
  const std::to_chars_result r = std::to_chars(p, end, v);
  if (r.ec != std::errc{}) return false;
  p = r.ptr;
  return true;
}

void check_column(const std::vector<std::string>& columns, std::size_t i) {
  const std::string& name = columns[i];
  const std::string where = "TraceWriter column " + std::to_string(i);
  if (name.empty()) throw std::invalid_argument(where + ": empty name");
  if (name.find_first_of(",\"\r\n") != std::string::npos)
    throw std::invalid_argument(where + " '" + name +
                                "': a name must not contain a comma, quote, CR or LF");
  if (name == "period" || name == "time_ns" || name == "flags")
    throw std::invalid_argument(where + " '" + name + "': reserved for the fixed columns");
}

std::vector<std::string> checked_columns(std::vector<std::string> columns) {
  if (columns.empty() || columns.size() > kTraceMaxColumns)
    throw std::invalid_argument("TraceWriter: 1.." + std::to_string(kTraceMaxColumns) +
                                " columns required (got " + std::to_string(columns.size()) + ")");
  std::unordered_set<std::string> seen;
  for (std::size_t i = 0; i < columns.size(); ++i) {
    check_column(columns, i);
    if (!seen.insert(columns[i]).second)
      throw std::invalid_argument("TraceWriter column " + std::to_string(i) + " '" + columns[i] +
                                  "': duplicate name");
  }
  return columns;
}

}  // namespace

TraceWriter::TraceWriter(const std::string& path, std::vector<std::string> columns,
                         const TraceWriterSettings& settings)
    : columns_(checked_columns(std::move(columns))),
      writer_(*this, settings, "TraceWriterSettings"),
      file_(path) {
  std::string header = "period,time_ns,flags";
  for (const std::string& c : columns_) header += ',' + c;
  header += '\n';
  if (!file_.write(header.data(), header.size()))
    throw std::runtime_error(path + ": cannot write the header");
}

TraceWriter::~TraceWriter() { close(); }

void TraceWriter::close() {
  if (!file_.is_open()) return;
  writer_.stop();
  writer_.drain();
  if (!file_.close()) writer_.count_io_error();
}

RealtimeStep TraceWriter::start(const std::vector<int>& writer_cpus) {
  std::promise<RealtimeStep> ready;
  std::future<RealtimeStep> step = ready.get_future();
  writer_.start([&ready, &writer_cpus] {
    // Never compete with the loop: drop an inherited real-time policy (always permitted).
    sched_param param{};
    param.sched_priority = 0;
    pthread_setschedparam(pthread_self(), SCHED_OTHER, &param);
    RealtimeStep affinity;
    try {
      if (!writer_cpus.empty()) {
        RealtimeSettings s;
        s.cpu_affinity = writer_cpus;
        affinity = apply_realtime(s).affinity;
      }
    } catch (const std::exception& e) {
      affinity = RealtimeStep{RealtimeStepStatus::kFailed, 0, e.what()};
    }
    ready.set_value(std::move(affinity));  // `ready` and `writer_cpus` are not used after this
  });
  return step.get();
}

hal::SinkResult TraceWriter::write(const TraceRecord& r) noexcept {
  char line[kLineBufferSize];
  char* const end = line + sizeof(line);
  char* p = line;
  bool ok = put(p, end, r.period, '\0') && put(p, end, r.time_ns, ',') && put(p, end, r.flags, ',');
  for (std::size_t i = 0; ok && i < columns_.size(); ++i) ok = put(p, end, r.values[i], ',');
  if (!ok || p == end) return hal::SinkResult::kFormatError;  // not with kLineBufferSize; never a cut line
  *p++ = '\n';
  return file_.write(line, static_cast<std::size_t>(p - line)) ? hal::SinkResult::kWritten
                                                               : hal::SinkResult::kIoError;
}

}  // namespace numen::platform
