// EvdevPointer + RelativePoseIntegrator on a real evdev node, inside the qemu guest of
// tests/hil/run.sh (the build host has no /dev/uinput). A virtual mouse is created through
// uinput with libevdev_uinput_create_from_device(); what the test writes into it comes back
// through the kernel's evdev handler as from a USB mouse. Needs the uinput and evdev modules
// (the guest's /init loads them) and root (the guest runs as root).
#include <gtest/gtest.h>
#include <libevdev/libevdev-uinput.h>
#include <libevdev/libevdev.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>

#include "alloc_counter.hpp"
#include "numen/hal/input/evdev_pointer.hpp"

namespace numen::hal {
namespace {

using core::Vec3;

constexpr double kSx = 1e-4;
constexpr double kSy = -1e-4;
constexpr double kSz = 2e-3;
constexpr double kSyaw = 0.05;

std::int64_t mono_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}

RelativePoseIntegratorSettings mouse_settings() {
  RelativePoseIntegratorSettings s;
  s.axes = {{REL_X, PoseDof::kX, kSx},
            {REL_Y, PoseDof::kY, kSy},
            {REL_WHEEL, PoseDof::kZ, kSz},
            {REL_HWHEEL, PoseDof::kYaw, kSyaw}};
  return s;
}

// A uinput mouse: REL_X, REL_Y, REL_WHEEL, REL_HWHEEL, BTN_RIGHT, BTN_MIDDLE and, unless
// with_left_button is false, BTN_LEFT.
class VirtualMouse {
 public:
  explicit VirtualMouse(const char* name, bool with_left_button = true) {
    libevdev* dev = libevdev_new();
    libevdev_set_name(dev, name);
    libevdev_set_id_bustype(dev, BUS_USB);
    libevdev_set_id_vendor(dev, 0x1d6b);
    libevdev_set_id_product(dev, 0x0104);
    libevdev_enable_event_type(dev, EV_REL);
    for (unsigned c : {REL_X, REL_Y, REL_WHEEL, REL_HWHEEL}) {
      libevdev_enable_event_code(dev, EV_REL, c, nullptr);
    }
    libevdev_enable_event_type(dev, EV_KEY);
    if (with_left_button) libevdev_enable_event_code(dev, EV_KEY, BTN_LEFT, nullptr);
    libevdev_enable_event_code(dev, EV_KEY, BTN_RIGHT, nullptr);
    libevdev_enable_event_code(dev, EV_KEY, BTN_MIDDLE, nullptr);
    const int rc = libevdev_uinput_create_from_device(dev, LIBEVDEV_UINPUT_OPEN_MANAGED, &ui_);
    libevdev_free(dev);
    if (rc < 0) {
      throw std::runtime_error(std::string("libevdev_uinput_create_from_device: ") +
                               std::strerror(-rc) + " (is the uinput module loaded?)");
    }
    const char* node = libevdev_uinput_get_devnode(ui_);
    if (node == nullptr) throw std::runtime_error("uinput device has no devnode (evdev module?)");
    node_ = node;
    // devtmpfs creates the node asynchronously.
    for (int i = 0; i < 200 && access(node_.c_str(), R_OK) != 0; ++i) usleep(10000);
  }
  ~VirtualMouse() { destroy(); }
  void destroy() {
    if (ui_ != nullptr) libevdev_uinput_destroy(ui_);
    ui_ = nullptr;
  }
  const std::string& node() const { return node_; }

  void write(unsigned type, unsigned code, int value) {
    ASSERT_EQ(libevdev_uinput_write_event(ui_, type, code, value), 0);
  }
  void syn() { write(EV_SYN, SYN_REPORT, 0); }
  void move(int dx, int dy) {
    if (dx != 0) write(EV_REL, REL_X, dx);
    if (dy != 0) write(EV_REL, REL_Y, dy);
    syn();
  }
  void button(unsigned code, int value) {
    write(EV_KEY, code, value);
    syn();
  }
  void wheel(unsigned code, int detents) {
    write(EV_REL, code, detents);
    syn();
  }

 private:
  libevdev_uinput* ui_ = nullptr;
  std::string node_;
};

// Polls until nothing is pending; returns the allocations made inside poll().
std::int64_t drain(EvdevPointer& p) {
  std::int64_t allocations = 0;
  for (int i = 0; i < 100; ++i) {
    test::AllocationGuard guard;
    const IoStatus s = p.poll();
    allocations += guard.count();
    EXPECT_NE(s, IoStatus::kError) << std::strerror(p.last_errno());
    if (s != IoStatus::kOk) break;
  }
  return allocations;
}

void expect_position(const RelativePoseIntegrator& in, const Vec3& p, const char* where) {
  EXPECT_NEAR((in.target().position - p).norm(), 0.0, 1e-15)
      << where << ": got " << in.target().position.transpose() << ", want " << p.transpose();
}

TEST(EvdevPointerHil, VirtualMouseDrivesTheTargetPoseThroughTheClutch) {
  VirtualMouse mouse("numen hil mouse");
  // The guest has no udev (no /dev/input/by-id): this finds the node by EVIOCGNAME.
  const std::string found = find_input_device("numen hil mouse");
  EXPECT_EQ(found, mouse.node());

  RelativePoseIntegrator in(mouse_settings());
  EvdevPointerSettings ps;
  ps.grab = true;
  EvdevPointer pointer(found, in, ps);
  EXPECT_EQ(pointer.name(), "numen hil mouse");
  EXPECT_TRUE(pointer.grabbed());
  EXPECT_TRUE(pointer.missing_axes().empty());
  EXPECT_EQ(pointer.poll(), IoStatus::kWouldBlock);

  std::int64_t allocations = 0;
  const std::int64_t t0 = mono_ns();
  mouse.move(5, -3);  // released: ignored
  allocations += drain(pointer);
  expect_position(in, Vec3::Zero(), "released");
  mouse.button(BTN_LEFT, 1);
  mouse.move(10, 4);
  mouse.move(7, 0);
  allocations += drain(pointer);
  expect_position(in, Vec3(17 * kSx, 4 * kSy, 0), "after two moves");
  mouse.wheel(REL_WHEEL, 1);
  mouse.button(BTN_LEFT, 0);
  mouse.move(100, 0);  // released: ignored
  mouse.button(BTN_LEFT, 1);
  mouse.wheel(REL_HWHEEL, 1);
  mouse.button(BTN_LEFT, 0);
  allocations += drain(pointer);
  const std::int64_t t1 = mono_ns();
  in.end_period(t1);

  expect_position(in, Vec3(17 * kSx, 4 * kSy, kSz), "end");
  const double yaw = 2.0 * std::atan2(in.target().orientation.z(), in.target().orientation.w());
  EXPECT_NEAR(yaw, kSyaw, 1e-15);
  EXPECT_FALSE(in.engaged());
  EXPECT_EQ(allocations, 0);
  EXPECT_EQ(in.counters().moving_reports, 4u);
  EXPECT_EQ(in.counters().ignored_reports, 2u);
  EXPECT_EQ(in.counters().dropped, 0u);
  EXPECT_EQ(pointer.counters().resyncs, 0u);
  // Event time stamps are CLOCK_MONOTONIC (libevdev_set_clock_id).
  EXPECT_GE(in.last_report_ns(), t0);
  EXPECT_LE(in.last_report_ns(), t1);
  std::printf("HIL-METRIC evdev_events=%llu evdev_reports=%llu\n",
              static_cast<unsigned long long>(pointer.counters().events),
              static_cast<unsigned long long>(in.counters().reports));

  // Grabbed: a second exclusive reader is refused.
  RelativePoseIntegrator other(mouse_settings());
  try {
    EvdevPointer second(found, other, ps);
    ADD_FAILURE() << "second grab succeeded";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("EVIOCGRAB"), std::string::npos) << e.what();
  }
}

TEST(EvdevPointerHil, BufferOverrunIsResyncedAndTheHeldClutchStaysEngaged) {
  VirtualMouse mouse("numen hil flood");
  RelativePoseIntegrator in(mouse_settings());
  EvdevPointer pointer(mouse.node(), in);
  mouse.button(BTN_LEFT, 1);
  mouse.move(1, 0);
  EXPECT_EQ(drain(pointer), 0);
  expect_position(in, Vec3(kSx, 0, 0), "before the flood");
  // Far more reports than evdev's client buffer holds (a few dozen events for a mouse):
  // the kernel drops and queues SYN_DROPPED.
  constexpr int kFlood = 2000;
  for (int i = 0; i < kFlood; ++i) mouse.move(1, 0);
  EXPECT_EQ(drain(pointer), 0);  // includes libevdev's resync
  EXPECT_GE(pointer.counters().resyncs, 1u);
  EXPECT_GE(in.counters().dropped, 1u);
  const double x_after = in.target().position.x();
  EXPECT_LT(x_after, (1 + kFlood) * kSx);  // some motion was lost
  // The key was held throughout: libevdev saw no change, sync_clutch_key() re-engaged.
  EXPECT_TRUE(in.engaged());
  mouse.move(5, 0);
  EXPECT_EQ(drain(pointer), 0);
  EXPECT_NEAR(in.target().position.x(), x_after + 5 * kSx, 1e-15);
  std::printf("HIL-METRIC evdev_flood_resyncs=%llu kept_counts=%.0f/%d\n",
              static_cast<unsigned long long>(pointer.counters().resyncs), x_after / kSx - 1,
              kFlood);
}

TEST(EvdevPointerHil, UnpluggedDeviceIsReportedGone) {
  auto mouse = std::make_unique<VirtualMouse>("numen hil unplug");
  RelativePoseIntegrator in(mouse_settings());
  EvdevPointer pointer(mouse->node(), in);
  mouse->destroy();
  IoStatus s = IoStatus::kWouldBlock;
  for (int i = 0; i < 100 && s != IoStatus::kError; ++i) {
    s = pointer.poll();
    if (s != IoStatus::kError) usleep(10000);
  }
  EXPECT_EQ(s, IoStatus::kError);
  EXPECT_TRUE(pointer.gone());
  EXPECT_EQ(pointer.last_errno(), ENODEV);
}

TEST(EvdevPointerHil, DeviceWithoutTheClutchKeyOrAxesIsRefused) {
  VirtualMouse mouse("numen hil no left", /*with_left_button=*/false);
  RelativePoseIntegrator in(mouse_settings());
  try {
    EvdevPointer p(mouse.node(), in);
    ADD_FAILURE() << "opened without BTN_LEFT";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("has no clutch key BTN_LEFT"), std::string::npos)
        << e.what();
  }
  RelativePoseIntegratorSettings s = mouse_settings();
  s.clutch_key = BTN_RIGHT;
  s.axes.push_back({REL_RX, PoseDof::kRoll, 0.01});
  RelativePoseIntegrator right(s);
  EvdevPointer p(mouse.node(), right);  // only REL_RX missing: listed, not an error
  ASSERT_EQ(p.missing_axes().size(), 1u);
  EXPECT_EQ(p.missing_axes()[0], REL_RX);
  EvdevPointerSettings strict;
  strict.require_all_axes = true;
  try {
    EvdevPointer q(mouse.node(), right, strict);
    ADD_FAILURE() << "opened without REL_RX";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("lacks the relative axes REL_RX"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace numen::hal
