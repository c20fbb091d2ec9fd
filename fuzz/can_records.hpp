// CAN frame records in fuzz inputs (fuzz_can_frames, fuzz_sdo_client, make_seeds).
#pragma once

#include "fl/drivers/can_frame.hpp"
#include "fuzz_input.hpp"

namespace fl::fuzz {

// Node ids of the emulated devices in fuzz_can_frames: none that config/can.yaml configures, so
// their boot-up messages and TPDOs never mark the master's own nodes rebooted or faulted.
inline constexpr std::uint8_t kEmulatedDriveNode = 100;
inline constexpr std::uint8_t kEmulatedIoNode = 101;

// A frame record: identifier (u32: the low 29 bits, bit 29 extended, bit 30 remote, bit 31
// error), DLC byte (not limited to 8: a broken transport or test double may pass any), then
// 8 data bytes.
inline constexpr std::uint32_t kFrameExtendedBit = 1U << 29U;
inline constexpr std::uint32_t kFrameRemoteBit = 1U << 30U;
inline constexpr std::uint32_t kFrameErrorBit = 1U << 31U;

inline drivers::CanFrame read_frame(FuzzInput& input) {
  drivers::CanFrame frame;
  const std::uint32_t word = input.u32();
  frame.extended = (word & kFrameExtendedBit) != 0U;
  frame.remote = (word & kFrameRemoteBit) != 0U;
  frame.error = (word & kFrameErrorBit) != 0U;
  frame.id = word & drivers::kCanExtendedIdMask;
  frame.dlc = input.u8();
  for (std::uint8_t& byte : frame.data) byte = input.u8();
  return frame;
}

inline void write_frame(SeedWriter& out, const drivers::CanFrame& frame) {
  out.u32((frame.id & drivers::kCanExtendedIdMask) | (frame.extended ? kFrameExtendedBit : 0U) |
          (frame.remote ? kFrameRemoteBit : 0U) | (frame.error ? kFrameErrorBit : 0U));
  out.u8(frame.dlc);
  out.bytes(frame.data);
}

}  // namespace fl::fuzz
