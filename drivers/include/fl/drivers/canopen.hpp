// CANopen (CiA 301) protocol elements the master and the emulated devices share: the
// predefined connection set's COB-IDs, NMT, SYNC, heartbeat, EMCY, expedited and segmented
// SDO frames with abort codes, and PDO mapping (pack/unpack by mapped object sizes).
// Pure functions on CanFrame: no I/O, no allocation.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>

#include "fl/drivers/can_frame.hpp"

namespace fl::drivers::canopen {

using NodeId = std::uint8_t;
inline constexpr NodeId kMinNodeId = 1;
inline constexpr NodeId kMaxNodeId = 127;
inline constexpr NodeId kAllNodes = 0;  // NMT broadcast

// Predefined connection set (CiA 301, 7.3.3): function code base + node id.
inline constexpr std::uint32_t kNmtCobId = 0x000;
inline constexpr std::uint32_t kSyncCobId = 0x080;
inline constexpr std::uint32_t kEmcyBase = 0x080;
inline constexpr std::array<std::uint32_t, 4> kTpdoBase = {0x180, 0x280, 0x380, 0x480};
inline constexpr std::array<std::uint32_t, 4> kRpdoBase = {0x200, 0x300, 0x400, 0x500};
inline constexpr std::uint32_t kSdoResponseBase = 0x580;  // server -> client
inline constexpr std::uint32_t kSdoRequestBase = 0x600;   // client -> server
inline constexpr std::uint32_t kHeartbeatBase = 0x700;
inline constexpr std::uint32_t kPdoCobIdInvalid = 0x80000000U;  // bit 31 of 0x14xx/0x18xx sub 1

// ---------------------------------------------------------------- NMT and heartbeat

enum class NmtCommand : std::uint8_t {
  kStart = 0x01,
  kStop = 0x02,
  kEnterPreOperational = 0x80,
  kResetNode = 0x81,
  kResetCommunication = 0x82,
};

enum class NmtState : std::uint8_t {
  kBootUp = 0x00,
  kStopped = 0x04,
  kOperational = 0x05,
  kPreOperational = 0x7F,
};
const char* to_string(NmtState state);

CanFrame make_nmt(NmtCommand command, NodeId node);  // node 0: every node
std::optional<NmtCommand> decode_nmt_command(std::uint8_t byte);
CanFrame make_sync();
CanFrame make_heartbeat(NodeId node, NmtState state);
// DLC must be 1 and the byte a defined state (the toggle bit 7 is node guarding only).
std::optional<NmtState> decode_heartbeat(const CanFrame& frame);

// ---------------------------------------------------------------- EMCY

struct Emergency {
  std::uint16_t error_code = 0;     // 0x0000: error reset / no error
  std::uint8_t error_register = 0;  // object 0x1001
  std::array<std::uint8_t, 5> manufacturer{};
};
CanFrame make_emcy(NodeId node, const Emergency& emergency);
// DLC must be 8 (CiA 301, 7.2.7.3.1).
std::optional<Emergency> decode_emcy(const CanFrame& frame);
// The error code's class from CiA 301 table 21 (and CiA 402 for drive-specific codes).
const char* describe_emcy_code(std::uint16_t error_code);

// ---------------------------------------------------------------- SDO

// Abort codes, CiA 301 table 22.
namespace sdo_abort {
inline constexpr std::uint32_t kToggleBit = 0x05030000;
inline constexpr std::uint32_t kTimeout = 0x05040000;
inline constexpr std::uint32_t kCommandSpecifier = 0x05040001;
inline constexpr std::uint32_t kUnsupportedAccess = 0x06010000;
inline constexpr std::uint32_t kWriteOnly = 0x06010001;
inline constexpr std::uint32_t kReadOnly = 0x06010002;
inline constexpr std::uint32_t kNoObject = 0x06020000;
inline constexpr std::uint32_t kNotMappable = 0x06040041;
inline constexpr std::uint32_t kPdoLengthExceeded = 0x06040042;
inline constexpr std::uint32_t kLengthMismatch = 0x06070010;
inline constexpr std::uint32_t kNoSubindex = 0x06090011;
inline constexpr std::uint32_t kInvalidValue = 0x06090030;
inline constexpr std::uint32_t kValueTooHigh = 0x06090031;
inline constexpr std::uint32_t kValueTooLow = 0x06090032;
inline constexpr std::uint32_t kGeneral = 0x08000000;
inline constexpr std::uint32_t kDeviceState = 0x08000022;
}  // namespace sdo_abort
const char* describe_sdo_abort(std::uint32_t abort_code);

struct SdoAddress {
  std::uint16_t index = 0;
  std::uint8_t subindex = 0;
  friend bool operator==(const SdoAddress&, const SdoAddress&) = default;
};

// Client requests (COB-ID 0x600 + node).
CanFrame make_sdo_download(NodeId node, SdoAddress address, std::uint32_t value,
                           std::uint8_t size_bytes);  // expedited, 1..4 bytes
CanFrame make_sdo_upload(NodeId node, SdoAddress address);
CanFrame make_sdo_upload_segment_request(NodeId node, bool toggle);
CanFrame make_sdo_abort(std::uint32_t cob_id, SdoAddress address, std::uint32_t abort_code);

// What a server answered (COB-ID 0x580 + node), decoded without judging it.
enum class SdoResponseKind : std::uint8_t {
  kDownloadDone,     // scs 3: initiate download response
  kUploadExpedited,  // scs 2 with e = 1
  kUploadSegmented,  // scs 2 with e = 0: segments follow
  kUploadSegment,    // scs 0: one segment
  kAbort,            // cs 4
  kInvalid,          // DLC != 8 or an unknown command specifier
};
struct SdoResponse {
  SdoResponseKind kind = SdoResponseKind::kInvalid;
  SdoAddress address;            // initiate responses and aborts
  std::uint32_t value = 0;       // expedited data, or the abort code
  std::uint8_t size_bytes = 0;   // expedited: 1..4; segmented initiate: total size (if < 256)
  std::uint32_t total_size = 0;  // segmented initiate with size indicated
  bool toggle = false;           // segment
  bool last_segment = false;     // segment: c bit
  std::array<std::uint8_t, 7> segment{};
  std::uint8_t segment_bytes = 0;
};
SdoResponse decode_sdo_response(const CanFrame& frame);

// Server side (emulated devices): what a client asked for.
enum class SdoRequestKind : std::uint8_t {
  kDownloadExpedited,
  kDownloadSegmented,  // not supported by the emulation: answered with an abort
  kUpload,
  kUploadSegment,
  kAbort,
  kInvalid,
};
struct SdoRequest {
  SdoRequestKind kind = SdoRequestKind::kInvalid;
  SdoAddress address;
  std::uint32_t value = 0;
  std::uint8_t size_bytes = 0;  // expedited download; 0 when the size was not indicated
  bool toggle = false;
};
SdoRequest decode_sdo_request(const CanFrame& frame);
CanFrame make_sdo_download_response(NodeId node, SdoAddress address);
CanFrame make_sdo_upload_expedited_response(NodeId node, SdoAddress address, std::uint32_t value,
                                            std::uint8_t size_bytes);
CanFrame make_sdo_upload_segmented_response(NodeId node, SdoAddress address,
                                            std::uint32_t total_size);
CanFrame make_sdo_upload_segment(NodeId node, bool toggle, std::span<const std::uint8_t> bytes,
                                 bool last);

// ---------------------------------------------------------------- PDO mapping

// One mapped object: index, subindex, length in bits (8, 16 or 32 here).
struct PdoEntry {
  std::uint16_t index = 0;
  std::uint8_t subindex = 0;
  std::uint8_t bits = 0;
  // The value of a mapping object's sub-entry (0x16xx/0x1Axx sub 1..8): index|sub|bits.
  [[nodiscard]] std::uint32_t mapping_value() const {
    return (static_cast<std::uint32_t>(index) << 16U) |
           (static_cast<std::uint32_t>(subindex) << 8U) | bits;
  }
  static PdoEntry from_mapping_value(std::uint32_t value) {
    return PdoEntry{static_cast<std::uint16_t>(value >> 16U),
                    static_cast<std::uint8_t>(value >> 8U), static_cast<std::uint8_t>(value)};
  }
};

inline constexpr std::size_t kMaxPdoEntries = 8;
struct PdoMapping {
  std::array<PdoEntry, kMaxPdoEntries> entries{};
  std::uint8_t count = 0;

  // Total length in bytes (whole-byte entries only, as every mapping of this project).
  [[nodiscard]] std::size_t bytes() const;
  // True when every entry is 8, 16 or 32 bits and the total fits 8 bytes.
  [[nodiscard]] bool valid() const;
};

// Packs `values` (one per entry, raw two's complement for signed objects) little-endian into
// a frame of exactly mapping.bytes(). values.size() must equal mapping.count.
CanFrame pack_pdo(std::uint32_t cob_id, const PdoMapping& mapping,
                  std::span<const std::uint32_t> values);
// Unpacks into `values`; false (nothing written) when the DLC differs from the mapping's
// length: CiA 301 lets a device process a longer PDO, but a mismatch means master and device
// disagree on the mapping, so this master refuses both.
bool unpack_pdo(const CanFrame& frame, const PdoMapping& mapping, std::span<std::uint32_t> values);

// The mappings this project uses (CiA 402 velocity mode, CiA 401 I/O). Written to every
// device by SDO at start-up, so a device's defaults never matter.
namespace layout {
// RPDO1 to a drive, synchronous: controlword, target velocity.
inline constexpr PdoMapping kDriveRpdo1{{{{0x6040, 0, 16}, {0x60FF, 0, 32}}}, 2};
// RPDO2 to a drive, event-driven (sent when changed): profile acceleration, deceleration.
inline constexpr PdoMapping kDriveRpdo2{{{{0x6083, 0, 32}, {0x6084, 0, 32}}}, 2};
// TPDO1 from a drive, every SYNC: statusword, position actual (the belt encoder).
inline constexpr PdoMapping kDriveTpdo1{{{{0x6041, 0, 16}, {0x6064, 0, 32}}}, 2};
// TPDO2 from a drive, every n-th SYNC: velocity actual.
inline constexpr PdoMapping kDriveTpdo2{{{{0x606C, 0, 32}}}, 1};
// I/O module TPDO1: 8 digital inputs, 3 analogue inputs (CiA 401 0x6000, 0x6401).
inline constexpr PdoMapping kIoTpdo1{
    {{{0x6000, 1, 8}, {0x6401, 1, 16}, {0x6401, 2, 16}, {0x6401, 3, 16}}}, 4};
// I/O module RPDO1: 8 digital outputs, 3 analogue outputs (CiA 401 0x6200, 0x6411).
inline constexpr PdoMapping kIoRpdo1{
    {{{0x6200, 1, 8}, {0x6411, 1, 16}, {0x6411, 2, 16}, {0x6411, 3, 16}}}, 4};
}  // namespace layout

// Worst-case length on the wire of a classic 11-bit data frame with `data_bytes` bytes,
// bit stuffing included (47 + 8n fixed bits, at most one stuff bit per 4 of the 34 + 8n
// stuffable bits), for the bus load estimate.
inline constexpr std::uint32_t worst_case_frame_bits(std::uint32_t data_bytes) {
  return 47U + 8U * data_bytes + (34U + 8U * data_bytes - 1U) / 4U;
}

}  // namespace fl::drivers::canopen
