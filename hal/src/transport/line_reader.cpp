/// @file line_reader.cpp
/// Line-at-a-time reading of a text file in a fixed buffer (see line_reader.hpp).

#include "numen/hal/transport/line_reader.hpp"

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <utility>

namespace numen::hal {

LineReader::LineReader(std::string path, std::size_t max_line)
    : path_(std::move(path)), max_line_(max_line) {
  if (max_line_ == 0) throw std::invalid_argument("LineReader: max_line must be >= 1");
  file_ = std::fopen(path_.c_str(), "rb");
  if (file_ == nullptr) {
    const int err = errno;
    throw std::runtime_error(path_ + ": cannot open: " + std::strerror(err));
  }
  buffer_ = std::make_unique<char[]>(2 * max_line_);
}

LineReader::~LineReader() {
  if (file_ != nullptr) std::fclose(file_);
}

bool LineReader::next(std::string_view& line, bool& cut) {
  cut = false;
  for (;;) {
    const char* data = buffer_.get();
    const void* nl = std::memchr(data + begin_, '\n', end_ - begin_);
    if (skip_rest_) {
      if (nl != nullptr) {
        begin_ = static_cast<std::size_t>(static_cast<const char*>(nl) - data) + 1;
        skip_rest_ = false;
        continue;
      }
      begin_ = end_ = 0;  // all of it belongs to the cut line
      if (eof_) return false;
    } else if (nl != nullptr) {
      const std::size_t at = static_cast<std::size_t>(static_cast<const char*>(nl) - data);
      cut = at - begin_ > max_line_;
      line = std::string_view(data + begin_, cut ? max_line_ : at - begin_);
      begin_ = at + 1;
      ++lines_;
      return true;
    } else if (end_ - begin_ > max_line_) {
      line = std::string_view(data + begin_, max_line_);
      cut = true;
      skip_rest_ = true;
      begin_ = end_;  // the view stays valid: the buffer is refilled at the next call
      ++lines_;
      return true;
    } else if (eof_) {
      if (begin_ == end_) return false;
      line = std::string_view(data + begin_, end_ - begin_);  // last line, no '\n'
      begin_ = end_;
      ++lines_;
      return true;
    }
    if (begin_ > 0) {
      std::memmove(buffer_.get(), data + begin_, end_ - begin_);
      end_ -= begin_;
      begin_ = 0;
    }
    const std::size_t got = std::fread(buffer_.get() + end_, 1, 2 * max_line_ - end_, file_);
    end_ += got;
    if (got == 0) {
      if (std::ferror(file_)) {
        const int err = errno;
        throw std::runtime_error(path_ + ":" + std::to_string(lines_ + 1) +
                                 ": read error: " + std::strerror(err));
      }
      eof_ = true;
    }
  }
}

}  // namespace numen::hal
