// The byte layouts the fuzz targets read and fuzz/make_seeds.cpp writes: a target takes its
// input apart with FuzzInput (reads past the end give zeros, so every input is usable) and
// the seed tool builds the same records with SeedWriter.
#pragma once

#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <vector>

namespace fl::fuzz {

class FuzzInput {
 public:
  FuzzInput(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}

  [[nodiscard]] bool empty() const { return position_ >= size_; }
  [[nodiscard]] std::size_t remaining() const { return empty() ? 0 : size_ - position_; }

  std::uint8_t u8() { return empty() ? 0 : data_[position_++]; }
  std::uint16_t u16() {
    const std::uint16_t low = u8();
    return static_cast<std::uint16_t>(low | (u8() << 8U));
  }
  std::uint32_t u32() {
    const std::uint32_t low = u16();
    return low | (static_cast<std::uint32_t>(u16()) << 16U);
  }
  std::uint64_t u64() {
    const std::uint64_t low = u32();
    return low | (static_cast<std::uint64_t>(u32()) << 32U);
  }
  std::int32_t i32() { return std::bit_cast<std::int32_t>(u32()); }
  std::int64_t i64() { return std::bit_cast<std::int64_t>(u64()); }
  // Any bit pattern: NaN, infinities and subnormals included.
  float f32() { return std::bit_cast<float>(u32()); }
  bool boolean() { return (u8() & 1U) != 0U; }

  // What is left, as one block (for the formats that take a whole buffer).
  std::span<const std::uint8_t> rest() {
    const std::span<const std::uint8_t> bytes(data_ + position_, remaining());
    position_ = size_;
    return bytes;
  }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t position_ = 0;
};

class SeedWriter {
 public:
  void u8(std::uint8_t value) { bytes_.push_back(value); }
  void u16(std::uint16_t value) {
    u8(static_cast<std::uint8_t>(value));
    u8(static_cast<std::uint8_t>(value >> 8U));
  }
  void u32(std::uint32_t value) {
    u16(static_cast<std::uint16_t>(value));
    u16(static_cast<std::uint16_t>(value >> 16U));
  }
  void u64(std::uint64_t value) {
    u32(static_cast<std::uint32_t>(value));
    u32(static_cast<std::uint32_t>(value >> 32U));
  }
  void i32(std::int32_t value) { u32(std::bit_cast<std::uint32_t>(value)); }
  void i64(std::int64_t value) { u64(std::bit_cast<std::uint64_t>(value)); }
  void f32(float value) { u32(std::bit_cast<std::uint32_t>(value)); }
  void boolean(bool value) { u8(value ? 1 : 0); }
  void bytes(std::span<const std::uint8_t> values) {
    bytes_.insert(bytes_.end(), values.begin(), values.end());
  }
  [[nodiscard]] const std::vector<std::uint8_t>& data() const { return bytes_; }

 private:
  std::vector<std::uint8_t> bytes_;
};

// fuzz_can_frames: one operation byte (modulo kCanOpCount), then its operands.
enum class CanOp : std::uint8_t {
  kFrame,      // a frame record: to the master and to the emulated devices
  kCycle,      // master read(), write(), devices polled, 10 ms pass
  kOutput,     // one output image member: selector byte, 4 value bytes
  kClockStep,  // u16 of 100 us steps pass, then a byte sets the transport's error state
  kCount
};
inline constexpr std::uint8_t kCanOpCount = static_cast<std::uint8_t>(CanOp::kCount);

// fuzz_sdo_client: one operation byte (modulo kSdoOpCount), then its operands.
enum class SdoOp : std::uint8_t {
  kUpload,     // node byte, index u16, subindex byte
  kDownload,   // node byte, index u16, subindex byte, value u32, size byte (1..4)
  kResponse,   // a frame record the bus hands out: bit 0 of a prefix byte sends it from the
               // node of the transfer (0x580 + node), otherwise the record's own identifier
  kQuietPoll,  // the bus has nothing this poll
  kCount
};
inline constexpr std::uint8_t kSdoOpCount = static_cast<std::uint8_t>(SdoOp::kCount);

// fuzz_dds_samples: one sample kind byte (modulo kDdsKindCount), then the sample's members in
// IDL order (fuzz_dds_samples.cpp reads them).
enum class DdsKind : std::uint8_t {
  kCameraEstimates,
  kLineSensors,
  kDriveFeedback,
  kLineCommand,
  kScan,  // the controller runs one 10 ms scan on the input image so far
  kCount
};
inline constexpr std::uint8_t kDdsKindCount = static_cast<std::uint8_t>(DdsKind::kCount);

// fuzz_cdr: a type byte (modulo kCdrTypeCount), then the CDR sample.
enum class CdrType : std::uint8_t {
  kCameraEstimates,
  kLineCommand,
  kLineStatus,
  kDriveFeedback,
  kLineSensors,
  kCompressedImage,
  kCount
};
inline constexpr std::uint8_t kCdrTypeCount = static_cast<std::uint8_t>(CdrType::kCount);

// fuzz_mcap_reader: a flags byte, then the file.
inline constexpr std::uint8_t kMcapValidateCrcs = 0x01;

}  // namespace fl::fuzz
