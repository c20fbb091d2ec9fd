// The names of drives, cameras, hands, sides and line states (process_image.hpp): one spelling,
// to_string and parse inverse to each other, and the spelling config/line.yaml uses.
#include <gtest/gtest.h>

#include <cstddef>
#include <cstdint>
#include <string_view>

#include "fl/controller/config_loader.hpp"
#include "fl/controller/process_image.hpp"

namespace fl {
namespace {

template <typename Id>
void expect_round_trip(std::size_t count) {
  for (std::size_t i = 0; i < count; ++i) {
    const auto id = static_cast<Id>(i);
    const std::string_view name = to_string(id);
    SCOPED_TRACE(name);
    EXPECT_NE(name, "");
    EXPECT_EQ(parse<Id>(name), id);
  }
}

TEST(Names, ToStringAndParseAreInverse) {
  expect_round_trip<DriveId>(kDriveCount);
  expect_round_trip<CameraId>(kCameraCount);
  expect_round_trip<Hand>(3);
  expect_round_trip<SideUp>(3);
  expect_round_trip<LineState>(5);
}

TEST(Names, SpellingOfTheConfigurationAndTheHmi) {
  EXPECT_EQ(to_string(DriveId::kMultilane1Left), "multilane1_left");
  EXPECT_EQ(to_string(CameraId::kOrientation), "orientation");
  EXPECT_EQ(to_string(Hand::kLeft), "left");
  EXPECT_EQ(to_string(Hand::kUnknown), "unknown");
  EXPECT_EQ(to_string(SideUp::kBone), "bone");
  EXPECT_EQ(to_string(LineState::kStopping), "stopping");
  EXPECT_EQ(config_name(DriveId::kOutfeed), to_string(DriveId::kOutfeed));
  EXPECT_EQ(config_name(CameraId::kFinal), to_string(CameraId::kFinal));
  static_assert(to_string(SideUp::kSkin) == "skin");
  static_assert(parse<DriveId>("takt") == DriveId::kTakt);
}

TEST(Names, OutsideTheEnumOrTable) {
  EXPECT_EQ(to_string(DriveId::kCount), "unknown");
  EXPECT_EQ(to_string(static_cast<Hand>(std::uint8_t{7})), "unknown");
  EXPECT_FALSE(parse<DriveId>("unknown").has_value());
  EXPECT_FALSE(parse<CameraId>("Orientation").has_value());  // exact spelling only
  EXPECT_FALSE(parse<SideUp>("").has_value());
}

}  // namespace
}  // namespace fl
