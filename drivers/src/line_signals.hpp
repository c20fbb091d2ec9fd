// Which line signal sits on which channel of the three CiA 401 I/O modules
// (config/can.yaml documents the same table), shared by the master (canopen_io.cpp) and the
// emulated line devices (line_devices.cpp), so that the two cannot disagree.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>

namespace fl::drivers::line_signals {

namespace infeed_io {
constexpr std::uint8_t kBeamBrokenBit = 0x01;
constexpr std::uint8_t kLevellerOverloadBit = 0x02;
constexpr std::size_t kLevelChannel = 0;
constexpr std::size_t kHopperOpeningChannel = 1;
constexpr std::size_t kLevellerSpeedChannel = 2;
constexpr std::size_t kHopperOpeningOut = 0;  // analogue outputs
constexpr std::size_t kLevellerSpeedOut = 1;
}  // namespace infeed_io
namespace stations_io {
constexpr std::uint8_t kPlate1FlippingBit = 0x01;
constexpr std::uint8_t kPlate2FlippingBit = 0x02;
constexpr std::uint8_t kSqueezeDownBit = 0x04;
constexpr std::size_t kCentringPositionChannel = 0;
constexpr std::uint8_t kPlate1FlipOut = 0x01;
constexpr std::uint8_t kPlate2FlipOut = 0x02;
constexpr std::uint8_t kCentringStrokeOut = 0x04;
constexpr std::uint8_t kSqueezeDownOut = 0x08;
constexpr std::uint8_t kFinalRejectOut = 0x10;
constexpr std::size_t kCentringShiftOut = 0;  // analogue output
}  // namespace stations_io
namespace safety_io {
constexpr std::uint8_t kEstopChainClosedBit = 0x01;
constexpr std::uint8_t kStartBit = 0x02;
constexpr std::uint8_t kStopBit = 0x04;
constexpr std::uint8_t kFaultResetBit = 0x08;
constexpr std::uint8_t kRunningLampOut = 0x01;
constexpr std::uint8_t kFaultLampOut = 0x02;
}  // namespace safety_io

// Engineering value to the 16-bit count of an analogue channel, rounded and clamped.
inline std::int16_t to_analog_counts(float value, float units_per_count) {
  // A NaN command has no count; the output's zero is its safe value (found by fuzzing: the
  // conversion of NaN to an integer is undefined behaviour).
  if (std::isnan(value)) {
    return 0;
  }
  const double counts =
      std::round(static_cast<double>(value) / static_cast<double>(units_per_count));
  return static_cast<std::int16_t>(std::clamp(counts, -32768.0, 32767.0));
}

// The 16-bit count back to the engineering value.
inline float from_analog_counts(std::int16_t counts, float units_per_count) {
  return static_cast<float>(counts) * units_per_count;
}

}  // namespace fl::drivers::line_signals
