#include "fl/drivers/canopen.hpp"

namespace fl::drivers::canopen {
namespace {

constexpr std::uint8_t kSdoFrameBytes = 8;  // every SDO frame has DLC 8 (CiA 301, 7.2.4.3)

CanFrame sdo_frame(std::uint32_t cob_id, std::uint8_t command, SdoAddress address) {
  CanFrame frame = make_frame(cob_id, kSdoFrameBytes);
  frame.data[0] = command;
  put_le(frame.data, 1, 2, address.index);
  frame.data[3] = address.subindex;
  return frame;
}

SdoAddress address_of(const CanFrame& frame) {
  return SdoAddress{static_cast<std::uint16_t>(get_le(frame.data, 1, 2)), frame.data[3]};
}

}  // namespace

const char* to_string(NmtState state) {
  switch (state) {
    case NmtState::kBootUp:
      return "boot-up";
    case NmtState::kStopped:
      return "stopped";
    case NmtState::kOperational:
      return "operational";
    case NmtState::kPreOperational:
      return "pre-operational";
  }
  return "unknown";
}

CanFrame make_nmt(NmtCommand command, NodeId node) {
  CanFrame frame = make_frame(kNmtCobId, 2);
  frame.data[0] = static_cast<std::uint8_t>(command);
  frame.data[1] = node;
  return frame;
}

std::optional<NmtCommand> decode_nmt_command(std::uint8_t byte) {
  switch (byte) {
    case 0x01:
    case 0x02:
    case 0x80:
    case 0x81:
    case 0x82:
      return static_cast<NmtCommand>(byte);
    default:
      return std::nullopt;
  }
}

CanFrame make_sync() { return make_frame(kSyncCobId, 0); }

CanFrame make_heartbeat(NodeId node, NmtState state) {
  CanFrame frame = make_frame(kHeartbeatBase + node, 1);
  frame.data[0] = static_cast<std::uint8_t>(state);
  return frame;
}

std::optional<NmtState> decode_heartbeat(const CanFrame& frame) {
  if (frame.dlc != 1) {
    return std::nullopt;
  }
  switch (frame.data[0] & 0x7FU) {  // bit 7 toggles only in node guarding replies
    case 0x00:
      return NmtState::kBootUp;
    case 0x04:
      return NmtState::kStopped;
    case 0x05:
      return NmtState::kOperational;
    case 0x7F:
      return NmtState::kPreOperational;
    default:
      return std::nullopt;
  }
}

CanFrame make_emcy(NodeId node, const Emergency& emergency) {
  CanFrame frame = make_frame(kEmcyBase + node, 8);
  put_le(frame.data, 0, 2, emergency.error_code);
  frame.data[2] = emergency.error_register;
  for (std::size_t i = 0; i < emergency.manufacturer.size(); ++i) {
    frame.data[3 + i] = emergency.manufacturer[i];
  }
  return frame;
}

std::optional<Emergency> decode_emcy(const CanFrame& frame) {
  if (frame.dlc != 8) {
    return std::nullopt;
  }
  Emergency emergency;
  emergency.error_code = static_cast<std::uint16_t>(get_le(frame.data, 0, 2));
  emergency.error_register = frame.data[2];
  for (std::size_t i = 0; i < emergency.manufacturer.size(); ++i) {
    emergency.manufacturer[i] = frame.data[3 + i];
  }
  return emergency;
}

const char* describe_emcy_code(std::uint16_t error_code) {
  // Specific codes first, then the class of the high byte/nibble (CiA 301 table 21).
  switch (error_code) {
    case 0x0000:
      return "error reset or no error";
    case 0x8110:
      return "CAN overrun (objects lost)";
    case 0x8120:
      return "CAN in error passive mode";
    case 0x8130:
      return "life guard or heartbeat error";
    case 0x8140:
      return "recovered from bus off";
    case 0x8210:
      return "PDO not processed due to length error";
    case 0x8220:
      return "PDO length exceeded";
    case 0x2310:
      return "continuous over current";
    case 0x3210:
      return "DC link over voltage";
    case 0x3220:
      return "DC link under voltage";
    case 0x4310:
      return "drive temperature too high";
    case 0x7121:
      return "motor blocked";
    case 0x8611:
      return "following error";
    default:
      break;
  }
  switch (error_code >> 12U) {
    case 0x1:
      return "generic error";
    case 0x2:
      return "current";
    case 0x3:
      return "voltage";
    case 0x4:
      return "temperature";
    case 0x5:
      return "device hardware";
    case 0x6:
      return "device software";
    case 0x7:
      return "additional modules";
    case 0x8:
      return "monitoring";
    case 0x9:
      return "external error";
    case 0xF:
      return (error_code >> 8U) == 0xFF ? "device specific" : "additional functions";
    default:
      return "unknown error class";
  }
}

const char* describe_sdo_abort(std::uint32_t abort_code) {
  switch (abort_code) {
    case 0x05030000:
      return "toggle bit not alternated";
    case 0x05040000:
      return "SDO protocol timed out";
    case 0x05040001:
      return "client/server command specifier not valid or unknown";
    case 0x05040002:
      return "invalid block size";
    case 0x05040005:
      return "out of memory";
    case 0x06010000:
      return "unsupported access to an object";
    case 0x06010001:
      return "attempt to read a write only object";
    case 0x06010002:
      return "attempt to write a read only object";
    case 0x06020000:
      return "object does not exist in the object dictionary";
    case 0x06040041:
      return "object cannot be mapped to the PDO";
    case 0x06040042:
      return "number and length of mapped objects would exceed PDO length";
    case 0x06040043:
      return "general parameter incompatibility";
    case 0x06040047:
      return "general internal incompatibility in the device";
    case 0x06060000:
      return "access failed due to a hardware error";
    case 0x06070010:
      return "data type does not match, length of service parameter does not match";
    case 0x06070012:
      return "data type does not match, length of service parameter too high";
    case 0x06070013:
      return "data type does not match, length of service parameter too low";
    case 0x06090011:
      return "sub-index does not exist";
    case 0x06090030:
      return "invalid value for parameter";
    case 0x06090031:
      return "value of parameter written too high";
    case 0x06090032:
      return "value of parameter written too low";
    case 0x06090036:
      return "maximum value is less than minimum value";
    case 0x060A0023:
      return "resource not available: SDO connection";
    case 0x08000000:
      return "general error";
    case 0x08000020:
      return "data cannot be transferred or stored to the application";
    case 0x08000021:
      return "data cannot be transferred or stored because of local control";
    case 0x08000022:
      return "data cannot be transferred or stored because of the present device state";
    case 0x08000023:
      return "object dictionary dynamic generation failed or no object dictionary";
    case 0x08000024:
      return "no data available";
    default:
      return "unknown abort code";
  }
}

CanFrame make_sdo_download(NodeId node, SdoAddress address, std::uint32_t value,
                           std::uint8_t size_bytes) {
  // ccs 1, e = 1, s = 1, n = 4 - size: 0x23 (4 bytes), 0x27, 0x2B, 0x2F (1 byte).
  const auto unused = static_cast<std::uint8_t>(4U - size_bytes);
  CanFrame frame =
      sdo_frame(kSdoRequestBase + node, static_cast<std::uint8_t>(0x23U | (unused << 2U)), address);
  put_le(frame.data, 4, size_bytes, value);
  return frame;
}

CanFrame make_sdo_upload(NodeId node, SdoAddress address) {
  return sdo_frame(kSdoRequestBase + node, 0x40, address);  // ccs 2
}

CanFrame make_sdo_upload_segment_request(NodeId node, bool toggle) {
  CanFrame frame = make_frame(kSdoRequestBase + node, kSdoFrameBytes);
  frame.data[0] = static_cast<std::uint8_t>(0x60U | (toggle ? 0x10U : 0U));  // ccs 3
  return frame;
}

CanFrame make_sdo_abort(std::uint32_t cob_id, SdoAddress address, std::uint32_t abort_code) {
  CanFrame frame = sdo_frame(cob_id, 0x80, address);  // cs 4
  put_le(frame.data, 4, 4, abort_code);
  return frame;
}

SdoResponse decode_sdo_response(const CanFrame& frame) {
  SdoResponse response;
  if (frame.dlc != kSdoFrameBytes) {
    return response;  // truncated (or padded beyond 8): kInvalid
  }
  const std::uint8_t command = frame.data[0];
  switch (command >> 5U) {
    case 3:  // initiate download response
      response.kind = SdoResponseKind::kDownloadDone;
      response.address = address_of(frame);
      break;
    case 2: {  // initiate upload response
      response.address = address_of(frame);
      const bool expedited = (command & 0x02U) != 0U;
      const bool size_indicated = (command & 0x01U) != 0U;
      if (expedited) {
        response.kind = SdoResponseKind::kUploadExpedited;
        response.size_bytes =
            size_indicated ? static_cast<std::uint8_t>(4U - ((command >> 2U) & 0x03U)) : 4U;
        response.value = get_le(frame.data, 4, response.size_bytes);
      } else {
        response.kind = SdoResponseKind::kUploadSegmented;
        response.total_size = size_indicated ? get_le(frame.data, 4, 4) : 0U;
      }
      break;
    }
    case 0: {  // upload segment response
      response.kind = SdoResponseKind::kUploadSegment;
      response.toggle = (command & 0x10U) != 0U;
      response.last_segment = (command & 0x01U) != 0U;
      response.segment_bytes = static_cast<std::uint8_t>(7U - ((command >> 1U) & 0x07U));
      for (std::size_t i = 0; i < response.segment_bytes; ++i) {
        response.segment[i] = frame.data[1 + i];
      }
      break;
    }
    case 4:  // abort
      response.kind = SdoResponseKind::kAbort;
      response.address = address_of(frame);
      response.value = get_le(frame.data, 4, 4);
      break;
    default:
      break;  // scs 1 (download segment response) is never expected: this client is expedited
  }
  return response;
}

SdoRequest decode_sdo_request(const CanFrame& frame) {
  SdoRequest request;
  if (frame.dlc != kSdoFrameBytes) {
    return request;
  }
  const std::uint8_t command = frame.data[0];
  switch (command >> 5U) {
    case 1: {  // initiate download
      request.address = address_of(frame);
      const bool expedited = (command & 0x02U) != 0U;
      const bool size_indicated = (command & 0x01U) != 0U;
      if (!expedited) {
        request.kind = SdoRequestKind::kDownloadSegmented;
        break;
      }
      request.kind = SdoRequestKind::kDownloadExpedited;
      request.size_bytes =
          size_indicated ? static_cast<std::uint8_t>(4U - ((command >> 2U) & 0x03U)) : 0U;
      request.value = get_le(frame.data, 4, size_indicated ? request.size_bytes : 4U);
      break;
    }
    case 2:
      request.kind = SdoRequestKind::kUpload;
      request.address = address_of(frame);
      break;
    case 3:
      request.kind = SdoRequestKind::kUploadSegment;
      request.toggle = (command & 0x10U) != 0U;
      break;
    case 4:
      request.kind = SdoRequestKind::kAbort;
      request.address = address_of(frame);
      request.value = get_le(frame.data, 4, 4);
      break;
    default:
      break;
  }
  return request;
}

CanFrame make_sdo_download_response(NodeId node, SdoAddress address) {
  return sdo_frame(kSdoResponseBase + node, 0x60, address);  // scs 3
}

CanFrame make_sdo_upload_expedited_response(NodeId node, SdoAddress address, std::uint32_t value,
                                            std::uint8_t size_bytes) {
  const auto unused = static_cast<std::uint8_t>(4U - size_bytes);
  CanFrame frame = sdo_frame(kSdoResponseBase + node,
                             static_cast<std::uint8_t>(0x43U | (unused << 2U)), address);
  put_le(frame.data, 4, size_bytes, value);
  return frame;
}

CanFrame make_sdo_upload_segmented_response(NodeId node, SdoAddress address,
                                            std::uint32_t total_size) {
  CanFrame frame = sdo_frame(kSdoResponseBase + node, 0x41, address);  // scs 2, s = 1, e = 0
  put_le(frame.data, 4, 4, total_size);
  return frame;
}

CanFrame make_sdo_upload_segment(NodeId node, bool toggle, std::span<const std::uint8_t> bytes,
                                 bool last) {
  CanFrame frame = make_frame(kSdoResponseBase + node, kSdoFrameBytes);
  const std::size_t count = bytes.size() < 7 ? bytes.size() : 7;
  frame.data[0] =
      static_cast<std::uint8_t>((toggle ? 0x10U : 0U) | ((7U - count) << 1U) | (last ? 0x01U : 0U));
  for (std::size_t i = 0; i < count; ++i) {
    frame.data[1 + i] = bytes[i];
  }
  return frame;
}

std::size_t PdoMapping::bytes() const {
  std::size_t bits = 0;
  for (std::size_t i = 0; i < count && i < kMaxPdoEntries; ++i) {
    bits += entries[i].bits;
  }
  return bits / 8;
}

bool PdoMapping::valid() const {
  if (count > kMaxPdoEntries) {
    return false;
  }
  std::size_t bits = 0;
  for (std::size_t i = 0; i < count; ++i) {
    const std::uint8_t length = entries[i].bits;
    if (length != 8 && length != 16 && length != 32) {
      return false;
    }
    bits += length;
  }
  return bits <= 64;
}

CanFrame pack_pdo(std::uint32_t cob_id, const PdoMapping& mapping,
                  std::span<const std::uint32_t> values) {
  CanFrame frame = make_frame(cob_id, static_cast<std::uint8_t>(mapping.bytes()));
  std::size_t offset = 0;
  for (std::size_t i = 0; i < mapping.count && i < values.size(); ++i) {
    const std::size_t bytes = mapping.entries[i].bits / 8U;
    put_le(frame.data, offset, bytes, values[i]);
    offset += bytes;
  }
  return frame;
}

bool unpack_pdo(const CanFrame& frame, const PdoMapping& mapping, std::span<std::uint32_t> values) {
  if (frame.dlc != mapping.bytes() || values.size() < mapping.count) {
    return false;
  }
  std::size_t offset = 0;
  for (std::size_t i = 0; i < mapping.count; ++i) {
    const std::size_t bytes = mapping.entries[i].bits / 8U;
    values[i] = get_le(frame.data, offset, bytes);
    offset += bytes;
  }
  return true;
}

}  // namespace fl::drivers::canopen
