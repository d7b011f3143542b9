// EvdevPointer on the build host, which has no input devices and no /dev/uinput: the setup
// errors and the device search. Reading a real (uinput) device is tested inside the HIL
// guest (tests/hil/evdev_pointer_hil_test.cpp, scenario 60-evdev_uinput).
#include "numen/hal/input/evdev_pointer.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

namespace numen::hal {
namespace {

namespace fs = std::filesystem;

std::string open_error(const std::string& path, const EvdevPointerSettings& s = {}) {
  RelativePoseIntegrator in;
  try {
    EvdevPointer p(path, in, s);
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

// A scratch directory removed at scope exit.
struct TempDir {
  fs::path path;
  TempDir() {
    char name[] = "/tmp/numen_evdev_XXXXXX";
    EXPECT_NE(mkdtemp(name), nullptr);
    path = name;
  }
  ~TempDir() { fs::remove_all(path); }
};

TEST(EvdevPointer, MissingDeviceNamesThePathAndHowToList) {
  const std::string msg = open_error("/dev/input/event-numen-none");
  EXPECT_NE(msg.find("input device /dev/input/event-numen-none: open: No such file or directory"),
            std::string::npos)
      << msg;
  EXPECT_NE(msg.find("ls -l /dev/input/by-id"), std::string::npos) << msg;
}

TEST(EvdevPointer, ANonEvdevFileIsRefused) {
  TempDir dir;
  const fs::path f = dir.path / "event0";
  std::ofstream(f) << "not a device\n";
  const std::string msg = open_error(f.string());
  EXPECT_NE(msg.find("libevdev_new_from_fd"), std::string::npos) << msg;
  EXPECT_NE(msg.find("not an evdev node"), std::string::npos) << msg;
  EXPECT_NE(open_error("/dev/null").find("libevdev_new_from_fd"), std::string::npos);
}

TEST(EvdevPointer, ZeroEventsPerPollIsRefused) {
  EvdevPointerSettings s;
  s.max_events_per_poll = 0;
  EXPECT_NE(open_error("/dev/null", s).find("max_events_per_poll"), std::string::npos);
}

TEST(EvdevPointer, PermissionDeniedGivesTheInputGroupHint) {
  // A file only root may read, opened by an unprivileged user: as root (the build machine),
  // a child process drops to uid/gid 65534 (nobody) and sends the message back.
  TempDir dir;
  chmod(dir.path.c_str(), 0755);
  const fs::path f = dir.path / "event0";
  std::ofstream(f) << "x";
  chmod(f.c_str(), 0600);
  std::string msg;
  if (geteuid() != 0) {
    chmod(f.c_str(), 0);
    msg = open_error(f.string());
  } else {
    int fds[2];
    ASSERT_EQ(pipe(fds), 0);
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      close(fds[0]);
      if (setgid(65534) != 0 || setuid(65534) != 0) _exit(2);
      const std::string m = open_error(f.string());
      const ssize_t n = write(fds[1], m.data(), m.size());
      _exit(n == static_cast<ssize_t>(m.size()) ? 0 : 3);
    }
    close(fds[1]);
    char buf[1024];
    ssize_t n = 0;
    while ((n = read(fds[0], buf, sizeof buf)) > 0) msg.append(buf, static_cast<std::size_t>(n));
    close(fds[0]);
    int status = 0;
    waitpid(pid, &status, 0);
    ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "child status " << status;
  }
  EXPECT_NE(msg.find("open: Permission denied"), std::string::npos) << msg;
  EXPECT_NE(msg.find("`input` group"), std::string::npos) << msg;
  EXPECT_NE(msg.find("udev rule"), std::string::npos) << msg;
}

TEST(EvdevPointer, FindsADeviceByItsByIdLink) {
  TempDir dir;
  fs::create_directories(dir.path / "by-id");
  std::ofstream(dir.path / "event3") << "";
  std::ofstream(dir.path / "mouse1") << "";
  // udev makes both a mousedev ("-mouse") and an evdev ("-event-mouse") link.
  fs::create_symlink("../mouse1", dir.path / "by-id" / "usb-Logitech_USB_Optical_Mouse-mouse");
  fs::create_symlink("../event3",
                     dir.path / "by-id" / "usb-Logitech_USB_Optical_Mouse-event-mouse");
  const std::string found = find_input_device("Logitech USB Optical Mouse",
                                              (dir.path / "by-id").string(), dir.path.string());
  EXPECT_EQ(found, fs::canonical(dir.path / "event3").string());
}

TEST(EvdevPointer, FindReportsWhatItSawWhenNothingMatches) {
  TempDir dir;
  std::ofstream(dir.path / "event0") << "";  // a plain file: libevdev refuses it
  std::ofstream(dir.path / "mice") << "";    // not an event node: not tried
  try {
    find_input_device("Some Mouse", (dir.path / "by-id").string(), dir.path.string());
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("no input device named 'Some Mouse'"), std::string::npos) << msg;
    EXPECT_NE(msg.find("could not open: " + (dir.path / "event0").string()), std::string::npos)
        << msg;
    EXPECT_EQ(msg.find("mice"), std::string::npos) << msg;
  }
  EXPECT_THROW(find_input_device(""), std::invalid_argument);
}

}  // namespace
}  // namespace numen::hal
