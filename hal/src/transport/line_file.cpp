/// @file line_file.cpp
/// LineFile: stdio file for record sinks, every failure returned.

#include "numen/hal/transport/line_file.hpp"

#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace numen::hal {

LineFile::LineFile(const std::string& path) : path_(path) {
  file_ = std::fopen(path.c_str(), "w");
  if (file_ == nullptr) {
    const int err = errno;
    throw std::runtime_error(path + ": cannot open for writing: " + std::strerror(err));
  }
}

LineFile::~LineFile() { close(); }

bool LineFile::write(const char* data, std::size_t size) noexcept {
  return file_ != nullptr && std::fwrite(data, 1, size, file_) == size;
}

bool LineFile::flush() noexcept { return file_ != nullptr && std::fflush(file_) == 0; }

bool LineFile::close() noexcept {
  if (file_ == nullptr) return true;
  const bool ok = std::fclose(file_) == 0;
  file_ = nullptr;
  return ok;
}

}  // namespace numen::hal
