#include "numen/hal/input/evdev_pointer.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <libevdev/libevdev.h>
#include <linux/input.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <utility>

namespace numen::hal {

namespace {

std::string errno_text(int err) { return std::strerror(err); }

std::string access_hint(int err) {
  if (err == EACCES || err == EPERM) {
    return "; event nodes are root:input 0660 on Debian: add the user to the `input` group "
           "(`sudo usermod -aG input $USER`, then log in again) or install a udev rule giving "
           "the device a group the user has (see evdev_pointer.hpp)";
  }
  if (err == ENOENT || err == ENODEV || err == ENXIO) {
    return "; list the devices with `ls -l /dev/input/by-id` or `evemu-describe`";
  }
  return "";
}

InputEvent to_input_event(const input_event& ev) noexcept {
  InputEvent e;
  e.time_ns = static_cast<std::int64_t>(ev.input_event_sec) * 1000000000 +
              static_cast<std::int64_t>(ev.input_event_usec) * 1000;
  e.type = ev.type;
  e.code = ev.code;
  e.value = ev.value;
  return e;
}

// Opens an event node and its libevdev context; on failure returns the negative errno and
// leaves nothing open.
int open_evdev(const std::string& path, int& fd, libevdev*& dev) noexcept {
  fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) return -errno;
  const int rc = libevdev_new_from_fd(fd, &dev);
  if (rc < 0) {
    ::close(fd);
    fd = -1;
    dev = nullptr;
    return rc;
  }
  return 0;
}

}  // namespace

EvdevPointer::EvdevPointer(const std::string& path, RelativePoseIntegrator& integrator,
                           const EvdevPointerSettings& settings)
    : integrator_(integrator), settings_(settings), path_(path) {
  if (settings.max_events_per_poll == 0) {
    throw std::invalid_argument("EvdevPointerSettings.max_events_per_poll: must be >= 1");
  }
  const std::string what = "input device " + path;
  fd_ = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd_ < 0) {
    const int err = errno;
    throw std::runtime_error(what + ": open: " + errno_text(err) + access_hint(err));
  }
  const int rc = libevdev_new_from_fd(fd_, &dev_);
  if (rc < 0) {
    ::close(fd_);
    fd_ = -1;
    dev_ = nullptr;
    throw std::runtime_error(what + ": libevdev_new_from_fd: " + errno_text(-rc) +
                             " (not an evdev node? use /dev/input/eventN)");
  }
  // From here on the destructor does not run if we throw: release by hand.
  auto fail = [&](const std::string& msg) {
    libevdev_free(dev_);
    ::close(fd_);
    dev_ = nullptr;
    fd_ = -1;
    throw std::runtime_error(what + " ('" + name_ + "'): " + msg);
  };
  const char* n = libevdev_get_name(dev_);
  name_ = n != nullptr ? n : "";
  const int crc = libevdev_set_clock_id(dev_, CLOCK_MONOTONIC);
  if (crc < 0) fail("libevdev_set_clock_id(CLOCK_MONOTONIC): " + errno_text(-crc));

  const RelativePoseIntegratorSettings& is = integrator.settings();
  if (is.clutch_mode != ClutchMode::kNone &&
      !libevdev_has_event_code(dev_, EV_KEY, is.clutch_key)) {
    const char* key = libevdev_event_code_get_name(EV_KEY, is.clutch_key);
    fail(std::string("has no clutch key ") + (key != nullptr ? key : "?") + " (code " +
         std::to_string(is.clutch_key) + "); choose another clutch_key or ClutchMode::kNone");
  }
  std::size_t present = 0;
  for (const RelAxisMapping& m : is.axes) {
    if (libevdev_has_event_code(dev_, EV_REL, m.code)) {
      ++present;
    } else if (std::find(missing_axes_.begin(), missing_axes_.end(), m.code) ==
               missing_axes_.end()) {
      missing_axes_.push_back(m.code);
    }
  }
  auto list_missing = [&] {
    std::string s;
    for (std::uint16_t c : missing_axes_) {
      const char* nm = libevdev_event_code_get_name(EV_REL, c);
      s += (s.empty() ? "" : ", ") + std::string(nm != nullptr ? nm : "?");
    }
    return s;
  };
  if (!is.axes.empty() && present == 0) {
    fail("has none of the mapped relative axes (" + list_missing() + "): not a pointer?");
  }
  if (settings.require_all_axes && !missing_axes_.empty()) {
    fail("lacks the relative axes " + list_missing() + " (require_all_axes)");
  }
  if (settings.grab) {
    const int grc = libevdev_grab(dev_, LIBEVDEV_GRAB);
    if (grc < 0) {
      fail("EVIOCGRAB: " + errno_text(-grc) +
           (grc == -EBUSY ? " (another client holds a grab)" : ""));
    }
    grabbed_ = true;
  }
}

EvdevPointer::~EvdevPointer() {
  if (dev_ != nullptr) {
    if (grabbed_) libevdev_grab(dev_, LIBEVDEV_UNGRAB);
    libevdev_free(dev_);
  }
  if (fd_ >= 0) ::close(fd_);
}

IoStatus EvdevPointer::poll() noexcept {
  if (dev_ == nullptr || gone_) return IoStatus::kError;
  std::size_t n = 0;
  input_event ev{};
  while (n < settings_.max_events_per_poll) {
    int rc = libevdev_next_event(dev_, LIBEVDEV_READ_FLAG_NORMAL, &ev);
    if (rc == LIBEVDEV_READ_STATUS_SUCCESS) {
      integrator_.feed(to_input_event(ev));
      ++counters_.events;
      ++n;
      continue;
    }
    if (rc == LIBEVDEV_READ_STATUS_SYNC) {
      // ev is the SYN_DROPPED. libevdev has re-read the device state; the differences come
      // as sync events, ending with a SYN_REPORT, until -EAGAIN (libevdev.h).
      ++counters_.resyncs;
      integrator_.drop_pending();
      while ((rc = libevdev_next_event(dev_, LIBEVDEV_READ_FLAG_SYNC, &ev)) ==
             LIBEVDEV_READ_STATUS_SYNC) {
        integrator_.feed(to_input_event(ev));
        ++counters_.events;
        ++counters_.sync_events;
        ++n;
      }
      const RelativePoseIntegratorSettings& is = integrator_.settings();
      if (is.clutch_mode != ClutchMode::kNone) {
        integrator_.sync_clutch_key(libevdev_get_event_value(dev_, EV_KEY, is.clutch_key) != 0);
      }
      if (rc == -EAGAIN) continue;  // sync done; normal events may follow
    }
    if (rc == -EAGAIN) break;
    if (rc == -ENODEV) {
      gone_ = true;
      last_errno_ = ENODEV;
      return IoStatus::kError;
    }
    ++counters_.read_errors;
    last_errno_ = -rc;
    return IoStatus::kError;
  }
  return n > 0 ? IoStatus::kOk : IoStatus::kWouldBlock;
}

namespace {

// udev's by-id names replace what is not [A-Za-z0-9.-] (and a few more) by '_'.
std::string by_id_form(std::string_view name) {
  std::string s(name);
  for (char& c : s) {
    const bool keep = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                      c == '.' || c == '-';
    if (!keep) c = '_';
  }
  return s;
}

std::vector<std::string> list_dir(const std::string& dir) {
  std::vector<std::string> out;
  DIR* d = ::opendir(dir.c_str());
  if (d == nullptr) return out;
  while (const dirent* e = ::readdir(d)) {
    const std::string n = e->d_name;
    if (n != "." && n != "..") out.push_back(n);
  }
  ::closedir(d);
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace

std::string find_input_device(std::string_view name, const std::string& by_id_dir,
                              const std::string& input_dir) {
  if (name.empty()) throw std::invalid_argument("find_input_device: empty name");
  const std::string wanted = by_id_form(name);
  for (const std::string& link : list_dir(by_id_dir)) {
    const std::size_t ev = link.rfind("-event-");
    if (ev == std::string::npos || link.find(wanted) == std::string::npos) continue;
    const std::string full = by_id_dir + "/" + link;
    char resolved[PATH_MAX];
    if (::realpath(full.c_str(), resolved) != nullptr) return resolved;
  }
  // Fallback: eventN in numeric order, by the name the kernel reports.
  std::vector<std::pair<long, std::string>> nodes;
  for (const std::string& f : list_dir(input_dir)) {
    if (f.rfind("event", 0) != 0 || f.size() == 5) continue;
    char* end = nullptr;
    const long k = std::strtol(f.c_str() + 5, &end, 10);
    if (end != nullptr && *end == '\0') nodes.emplace_back(k, f);
  }
  std::sort(nodes.begin(), nodes.end());
  std::string seen;
  std::string refused;
  bool denied = false;
  for (const auto& [k, f] : nodes) {
    (void)k;
    const std::string path = input_dir + "/" + f;
    int fd = -1;
    libevdev* dev = nullptr;
    const int rc = open_evdev(path, fd, dev);
    if (rc < 0) {
      refused += (refused.empty() ? "" : ", ") + path + ": " + errno_text(-rc);
      denied = denied || rc == -EACCES || rc == -EPERM;
      continue;
    }
    const char* n = libevdev_get_name(dev);
    const std::string devname = n != nullptr ? n : "";
    libevdev_free(dev);
    ::close(fd);
    if (devname.find(name) != std::string::npos) return path;
    seen += (seen.empty() ? "" : ", ") + f + " '" + devname + "'";
  }
  std::string msg = "no input device named '" + std::string(name) + "' in " + by_id_dir + " or " +
                    input_dir + "/event*";
  msg += "; devices: " + (seen.empty() ? std::string("none readable") : seen);
  if (!refused.empty()) msg += "; could not open: " + refused;
  if (denied) msg += access_hint(EACCES);
  throw std::runtime_error(msg);
}

}  // namespace numen::hal
