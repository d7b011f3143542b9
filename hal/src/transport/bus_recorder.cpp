/// @file bus_recorder.cpp
/// Non-blocking bus recording: a lock-free SPSC queue from the control loop to a writer
/// thread that formats candump log lines into a file written with write(2) (CountedLineFile).

#include "numen/hal/transport/bus_recorder.hpp"

namespace numen::hal {

CandumpWriter::CandumpWriter(const std::string& path, const CandumpWriterSettings& settings)
    : settings_(settings),
      writer_(*this, settings, "CandumpWriterSettings"),
      file_(path) {}

CandumpWriter::~CandumpWriter() { close(); }

void CandumpWriter::close() {
  if (!file_.is_open()) return;
  writer_.stop();
  writer_.drain();
  writer_.flush_sink();
  if (!file_.close()) writer_.count_io_error();
}

SinkResult CandumpWriter::write(const CandumpRecord& record) noexcept {
  char line[kCandumpLineBufferSize];
  const CandumpDirection direction =
      settings_.mark_direction ? record.direction : CandumpDirection::kUnmarked;
  std::int64_t t_ns = 0;
  if (__builtin_add_overflow(record.frame.timestamp_ns, settings_.time_offset_ns, &t_ns))
    return SinkResult::kFormatError;
  const CandumpFormatResult r = format_candump_line(t_ns, record.iface, record.frame, direction, line);
  if (!r.ok()) return SinkResult::kFormatError;
  line[r.length] = '\n';
  return file_.append(line, r.length + 1) ? SinkResult::kBuffered : SinkResult::kIoError;
}

SinkSettled CandumpWriter::take_settled() noexcept {
  const LineCounts c = file_.take_counts();
  return SinkSettled{c.written, c.lost, c.failed_writes};
}

RecordingBus::RecordingBus(Bus& inner, CandumpWriter& writer, std::string_view iface)
    : inner_(&inner), writer_(&writer), iface_(make_candump_iface(iface, "RecordingBus iface")) {}

void RecordingBus::record(const CanFrame& frame, CandumpDirection direction) noexcept {
  if (writer_->push(frame, iface_, direction)) {
    ++counters_.recorded;
  } else {
    ++counters_.dropped;
  }
}

IoStatus RecordingBus::read(CanFrame& frame) noexcept {
  const IoStatus status = inner_->read(frame);
  if (status == IoStatus::kOk) record(frame, CandumpDirection::kReceived);
  return status;
}

IoStatus RecordingBus::write(const CanFrame& frame) noexcept {
  const IoStatus status = inner_->write(frame);
  if (status == IoStatus::kOk) record(frame, CandumpDirection::kTransmitted);
  return status;
}

}  // namespace numen::hal
