// A classic CAN 2.0A/B data frame as the drivers pass it around: fixed size and trivially
// copyable, so receive batches live in preallocated arrays. CANopen is little-endian on the
// wire (CiA 301, 7.1.2): the put_le/get_le helpers are the only place bytes get packed.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <type_traits>

namespace fl::drivers {

inline constexpr std::size_t kCanMaxDataBytes = 8;  // classic CAN; CAN FD is not used here
inline constexpr std::uint32_t kCanStandardIdMask = 0x7FF;
inline constexpr std::uint32_t kCanExtendedIdMask = 0x1FFFFFFF;

struct CanFrame {
  std::uint32_t id = 0;   // 11-bit (or 29-bit when `extended`) identifier, no flag bits
  std::uint8_t dlc = 0;   // 0..8 data bytes
  bool extended = false;  // 29-bit identifier (CANopen uses 11-bit: such frames are refused)
  bool remote = false;    // RTR: CANopen masters do not use it (CiA AN 802)
  bool error = false;     // a SocketCAN error frame: `id` holds the CAN_ERR_* class bits
  std::array<std::uint8_t, kCanMaxDataBytes> data{};
  std::int64_t timestamp_ns = 0;  // receive time (kernel SO_TIMESTAMPNS or the loopback clock)
};
static_assert(std::is_trivially_copyable_v<CanFrame>);

// Little-endian packing of an unsigned or signed integer of 1..4 bytes at `offset`.
// The caller checks that offset + bytes <= 8; these never read or write past `data`.
inline void put_le(std::array<std::uint8_t, kCanMaxDataBytes>& data, std::size_t offset,
                   std::size_t bytes, std::uint32_t value) {
  for (std::size_t i = 0; i < bytes && offset + i < kCanMaxDataBytes; ++i) {
    data[offset + i] = static_cast<std::uint8_t>(value >> (8U * i));
  }
}

inline std::uint32_t get_le(const std::array<std::uint8_t, kCanMaxDataBytes>& data,
                            std::size_t offset, std::size_t bytes) {
  std::uint32_t value = 0;
  for (std::size_t i = 0; i < bytes && offset + i < kCanMaxDataBytes; ++i) {
    value |= static_cast<std::uint32_t>(data[offset + i]) << (8U * i);
  }
  return value;
}

// Sign-extends the low `bits` bits of `raw` (two's complement on the wire).
inline std::int32_t sign_extend(std::uint32_t raw, unsigned bits) {
  if (bits >= 32U) {
    std::int32_t value = 0;
    std::memcpy(&value, &raw, sizeof value);
    return value;
  }
  const std::uint32_t sign_bit = 1U << (bits - 1U);
  const std::uint32_t masked = raw & ((1U << bits) - 1U);
  const std::int64_t value =
      static_cast<std::int64_t>(masked ^ sign_bit) - static_cast<std::int64_t>(sign_bit);
  return static_cast<std::int32_t>(value);
}

inline std::uint32_t to_wire(std::int32_t value) {
  std::uint32_t raw = 0;
  std::memcpy(&raw, &value, sizeof raw);
  return raw;
}

inline CanFrame make_frame(std::uint32_t id, std::uint8_t dlc) {
  CanFrame frame;
  frame.id = id;
  frame.dlc = dlc;
  return frame;
}

}  // namespace fl::drivers
