// Tests of hal/input/event_code_name: evdev code names through libevdev, and a build without
// libevdev resolving none.
#include "numen/hal/input/event_code_name.hpp"

#include <gtest/gtest.h>

#include "numen/hal/features.hpp"
#include "numen/hal/input/input_event.hpp"

namespace numen::hal {
namespace {

TEST(EventCodeName, NamesOfTheKernelHeaderAreTheirCodes) {
  if (!kWithEvdev) {
    EXPECT_FALSE(event_code_names_available());
    EXPECT_FALSE(event_code_from_name(EV_REL, "REL_X").has_value());
    GTEST_SKIP() << "NUMEN_WITH_EVDEV=OFF: no name resolves (checked)";
  }
  EXPECT_TRUE(event_code_names_available());
  EXPECT_EQ(event_code_from_name(EV_REL, "REL_X"), REL_X);
  EXPECT_EQ(event_code_from_name(EV_REL, "REL_Y"), REL_Y);
  EXPECT_EQ(event_code_from_name(EV_REL, "REL_WHEEL"), REL_WHEEL);
  EXPECT_EQ(event_code_from_name(EV_REL, "REL_HWHEEL"), REL_HWHEEL);
  EXPECT_EQ(event_code_from_name(EV_KEY, "BTN_LEFT"), BTN_LEFT);
  EXPECT_EQ(event_code_from_name(EV_KEY, "BTN_MIDDLE"), BTN_MIDDLE);
  EXPECT_EQ(event_code_from_name(EV_KEY, "KEY_SPACE"), KEY_SPACE);
}

TEST(EventCodeName, ANameOfAnotherTypeOrCaseOrNothingIsNone) {
  EXPECT_FALSE(event_code_from_name(EV_REL, "BTN_LEFT").has_value());  // an EV_KEY name
  EXPECT_FALSE(event_code_from_name(EV_KEY, "REL_X").has_value());     // an EV_REL name
  EXPECT_FALSE(event_code_from_name(EV_REL, "rel_x").has_value());     // case sensitive
  EXPECT_FALSE(event_code_from_name(EV_REL, "REL_Q").has_value());
  EXPECT_FALSE(event_code_from_name(EV_REL, "").has_value());
  EXPECT_FALSE(event_code_from_name(EV_REL, std::string_view("REL_X\0junk", 10)).has_value());
  // A prefix of a longer string: only the given length counts.
  EXPECT_EQ(event_code_from_name(EV_REL, std::string_view("REL_XYZ", 5)),
            kWithEvdev ? std::optional<std::uint16_t>(REL_X) : std::nullopt);
}

}  // namespace
}  // namespace numen::hal
