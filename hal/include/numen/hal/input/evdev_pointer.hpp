#pragma once
/// @file evdev_pointer.hpp
/// EvdevPointer: a Linux input device (/dev/input/eventN: a mouse, a trackball, a 3D mouse)
/// read through libevdev (Debian package libevdev-dev) without blocking, once per control
/// period, feeding a RelativePoseIntegrator. libevdev handles the kernel's SYN_DROPPED:
/// libevdev_next_event() returns LIBEVDEV_READ_STATUS_SYNC, the reader then takes the state
/// differences with LIBEVDEV_READ_FLAG_SYNC until -EAGAIN (libevdev.h, "SYN_DROPPED
/// handling"); EvdevPointer does that, telling the integrator (drop_pending(), then the sync
/// events, then sync_clutch_key() with the key state libevdev re-read).
///
/// Access: event nodes are root:input, mode 0660, on Debian. A user needs the `input` group
/// (`sudo usermod -aG input $USER`, log in again) or a udev rule, e.g. in
/// /etc/udev/rules.d/70-numen-pointer.rules:
///     KERNEL=="event*", SUBSYSTEM=="input", ATTRS{name}=="<device name>", MODE="0660",
///     GROUP="plugdev"
/// Exclusive grab (EvdevPointerSettings::grab, EVIOCGRAB through libevdev_grab()): while
/// grabbed, no other client (the X server / Wayland compositor, the console) receives the
/// device's events, so the mouse driving the tool does not also move the desktop pointer.
/// The grab ends with the EvdevPointer (or the process).
///
/// Time stamps are CLOCK_MONOTONIC (libevdev_set_clock_id, EVIOCSCLOCKID), as the control
/// loop's clock.

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "numen/hal/transport/bus.hpp"
#include "numen/hal/input/relative_pose_integrator.hpp"

struct libevdev;

namespace numen::hal {

/// Creation settings of an EvdevPointer.
struct EvdevPointerSettings {
  /// Grab the device exclusively (EVIOCGRAB; see the file comment). Fails at open if another
  /// client holds a grab.
  bool grab = false;
  /// Every REL axis the integrator maps must exist on the device (libevdev_has_event_code);
  /// otherwise only at least one must, and the others are listed in missing_axes().
  bool require_all_axes = false;
  /// Most events one poll() takes (bounds its time under a flood); >= 1.
  std::size_t max_events_per_poll = 1024;
};

/// Counters of an EvdevPointer since open.
struct EvdevPointerCounters {
  std::uint64_t events = 0;       ///< Events fed to the integrator (sync events included).
  std::uint64_t resyncs = 0;      ///< SYN_DROPPED seen: libevdev resynchronised the state.
  std::uint64_t sync_events = 0;  ///< Events delivered in sync mode (state differences).
  std::uint64_t read_errors = 0;  ///< libevdev_next_event() errors other than -EAGAIN.
};

/// Reads one evdev device into a RelativePoseIntegrator (which must outlive it). Not
/// copyable, not thread safe. poll() is noexcept, does not block and allocates nothing.
class EvdevPointer {
 public:
  /// Opens `path` (O_RDONLY | O_NONBLOCK | O_CLOEXEC), creates the libevdev context, sets
  /// the clock to CLOCK_MONOTONIC, checks the capabilities and grabs if asked. Throws
  /// std::runtime_error naming the path and the cause: no such device; permission denied
  /// (with the `input` group / udev hint); not an evdev device; the clutch key missing
  /// (unless the integrator's clutch mode is kNone); none of the mapped REL axes (or, with
  /// require_all_axes, any one of them) present; grab refused (another client grabbed it).
  /// std::invalid_argument if max_events_per_poll is 0.
  EvdevPointer(const std::string& path, RelativePoseIntegrator& integrator,
               const EvdevPointerSettings& settings = {});
  ~EvdevPointer();
  EvdevPointer(const EvdevPointer&) = delete;
  EvdevPointer& operator=(const EvdevPointer&) = delete;

  /// Reads every pending event (at most max_events_per_poll) and feeds the integrator.
  /// kOk: at least one event; kWouldBlock: none pending; kError: the device is gone
  /// (unplugged, -ENODEV; see gone()) or a read failed (last_errno()). Events read before an
  /// error were fed. Does not call integrator.end_period(): the caller does, once per period.
  IoStatus poll() noexcept;

  /// True after the device disappeared (-ENODEV); open a new EvdevPointer when it is back.
  bool gone() const noexcept { return gone_; }
  /// errno of the last failed read, 0 if none.
  int last_errno() const noexcept { return last_errno_; }
  /// Counters.
  const EvdevPointerCounters& counters() const noexcept { return counters_; }
  /// The device's name (EVIOCGNAME), e.g. "Logitech USB Optical Mouse".
  const std::string& name() const noexcept { return name_; }
  /// The path opened.
  const std::string& path() const noexcept { return path_; }
  /// Mapped REL codes the device does not have (their mappings never fire).
  const std::vector<std::uint16_t>& missing_axes() const noexcept { return missing_axes_; }
  /// True if the device is grabbed.
  bool grabbed() const noexcept { return grabbed_; }
  /// The file descriptor (for poll()/epoll in a loop that waits on several sources).
  int fd() const noexcept { return fd_; }

 private:
  RelativePoseIntegrator& integrator_;
  EvdevPointerSettings settings_;
  std::string path_;
  std::string name_;
  std::vector<std::uint16_t> missing_axes_;
  int fd_ = -1;
  ::libevdev* dev_ = nullptr;
  bool grabbed_ = false;
  bool gone_ = false;
  int last_errno_ = 0;
  EvdevPointerCounters counters_{};
};

/// Finds the event node of the input device whose name contains `name` (setup code, may
/// allocate). First looks in `by_id_dir` for a symbolic link whose file name contains `name`
/// with every character other than [A-Za-z0-9.-] replaced by '_' (udev's by-id naming, e.g.
/// usb-Logitech_USB_Optical_Mouse-event-mouse) and ends in an "event-…" part; then opens each
/// `input_dir`/eventN in numeric order and compares the device name (EVIOCGNAME through
/// libevdev) with `name` (substring). Returns the event node path (links resolved). Throws
/// std::runtime_error "no input device named '<name>'" listing the names it could read, and
/// the nodes it could not open (with errno text: usually the `input` group is missing).
std::string find_input_device(std::string_view name,
                              const std::string& by_id_dir = "/dev/input/by-id",
                              const std::string& input_dir = "/dev/input");

}  // namespace numen::hal
