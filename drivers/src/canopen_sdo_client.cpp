#include "fl/drivers/canopen_sdo_client.hpp"

#include <time.h>

#include <cstdio>

namespace fl::drivers {

using canopen::NodeId;
using canopen::SdoAddress;
using canopen::SdoResponse;
using canopen::SdoResponseKind;

BusClock monotonic_bus_clock() {
  return BusClock{[] {
                    timespec now{};
                    clock_gettime(CLOCK_MONOTONIC, &now);
                    return static_cast<std::int64_t>(now.tv_sec) * 1'000'000'000 + now.tv_nsec;
                  },
                  [](std::int64_t duration_ns) {
                    if (duration_ns <= 0) {
                      return;
                    }
                    timespec pause{static_cast<time_t>(duration_ns / 1'000'000'000),
                                   static_cast<long>(duration_ns % 1'000'000'000)};
                    nanosleep(&pause, nullptr);
                  }};
}

const char* to_string(SdoStatus status) {
  switch (status) {
    case SdoStatus::kOk:
      return "ok";
    case SdoStatus::kAborted:
      return "aborted by the device";
    case SdoStatus::kTimeout:
      return "timed out";
    case SdoStatus::kProtocolError:
      return "protocol error";
    case SdoStatus::kSendFailed:
      return "send failed";
  }
  return "unknown";
}

std::string SdoResult::describe() const {
  if (status == SdoStatus::kOk || status == SdoStatus::kSendFailed) {
    return to_string(status);
  }
  char code[16];
  std::snprintf(code, sizeof code, "0x%08X", abort_code);
  return std::string(to_string(status)) + ": " + code + " " +
         canopen::describe_sdo_abort(abort_code);
}

SdoClient::SdoClient(CanBus& bus, BusClock clock, std::int64_t timeout_ns,
                     std::function<void(const CanFrame&)> other_frames)
    : bus_(bus),
      clock_(std::move(clock)),
      timeout_ns_(timeout_ns),
      other_frames_(std::move(other_frames)) {}

std::optional<SdoResponse> SdoClient::await_response(NodeId node, std::int64_t deadline_ns) {
  const std::uint32_t response_id = canopen::kSdoResponseBase + node;
  while (true) {
    while (batch_next_ < batch_size_) {
      const CanFrame& frame = batch_[batch_next_++];
      if (frame.id == response_id && !frame.extended && !frame.remote) {
        return canopen::decode_sdo_response(frame);
      }
      if (other_frames_) {
        other_frames_(frame);
      }
    }
    batch_next_ = 0;
    batch_size_ = bus_.receive(batch_);
    if (batch_size_ > 0) {
      continue;
    }
    if (clock_.now_ns() >= deadline_ns) {
      return std::nullopt;
    }
    clock_.wait_ns(kPollStepNs);
  }
}

SdoResult SdoClient::fail(NodeId node, SdoAddress address, SdoStatus status,
                          std::uint32_t abort_code) {
  // Tell the server the transfer is over, so that it does not wait for segments.
  bus_.send(canopen::make_sdo_abort(canopen::kSdoRequestBase + node, address, abort_code));
  SdoResult result;
  result.status = status;
  result.abort_code = abort_code;
  return result;
}

SdoResult SdoClient::download(NodeId node, SdoAddress address, std::uint32_t value,
                              std::uint8_t size_bytes) {
  ++counters_.transfers;
  if (!bus_.send(canopen::make_sdo_download(node, address, value, size_bytes))) {
    return SdoResult{SdoStatus::kSendFailed, 0, 0, 0, {}};
  }
  const auto response = await_response(node, clock_.now_ns() + timeout_ns_);
  if (!response) {
    ++counters_.timeouts;
    return fail(node, address, SdoStatus::kTimeout, canopen::sdo_abort::kTimeout);
  }
  switch (response->kind) {
    case SdoResponseKind::kAbort:
      ++counters_.aborts_received;
      return SdoResult{SdoStatus::kAborted, 0, 0, response->value, {}};
    case SdoResponseKind::kDownloadDone:
      if (response->address == address) {
        return SdoResult{};
      }
      ++counters_.unexpected_responses;
      return fail(node, address, SdoStatus::kProtocolError, canopen::sdo_abort::kGeneral);
    case SdoResponseKind::kInvalid:
      ++counters_.malformed_responses;
      return fail(node, address, SdoStatus::kProtocolError, canopen::sdo_abort::kCommandSpecifier);
    default:
      ++counters_.unexpected_responses;
      return fail(node, address, SdoStatus::kProtocolError, canopen::sdo_abort::kCommandSpecifier);
  }
}

SdoResult SdoClient::upload(NodeId node, SdoAddress address) {
  ++counters_.transfers;
  if (!bus_.send(canopen::make_sdo_upload(node, address))) {
    return SdoResult{SdoStatus::kSendFailed, 0, 0, 0, {}};
  }
  auto response = await_response(node, clock_.now_ns() + timeout_ns_);
  if (!response) {
    ++counters_.timeouts;
    return fail(node, address, SdoStatus::kTimeout, canopen::sdo_abort::kTimeout);
  }
  switch (response->kind) {
    case SdoResponseKind::kAbort:
      ++counters_.aborts_received;
      return SdoResult{SdoStatus::kAborted, 0, 0, response->value, {}};
    case SdoResponseKind::kUploadExpedited:
      if (!(response->address == address)) {
        ++counters_.unexpected_responses;
        return fail(node, address, SdoStatus::kProtocolError, canopen::sdo_abort::kGeneral);
      }
      return SdoResult{SdoStatus::kOk, response->value, response->size_bytes, 0, {}};
    case SdoResponseKind::kUploadSegmented:
      if (!(response->address == address)) {
        ++counters_.unexpected_responses;
        return fail(node, address, SdoStatus::kProtocolError, canopen::sdo_abort::kGeneral);
      }
      break;  // segments follow
    case SdoResponseKind::kInvalid:
      ++counters_.malformed_responses;
      return fail(node, address, SdoStatus::kProtocolError, canopen::sdo_abort::kCommandSpecifier);
    default:
      ++counters_.unexpected_responses;
      return fail(node, address, SdoStatus::kProtocolError, canopen::sdo_abort::kCommandSpecifier);
  }

  const std::uint32_t total_size = response->total_size;  // 0: not indicated
  SdoResult result;
  bool toggle = false;
  while (true) {
    if (!bus_.send(canopen::make_sdo_upload_segment_request(node, toggle))) {
      return SdoResult{SdoStatus::kSendFailed, 0, 0, 0, {}};
    }
    response = await_response(node, clock_.now_ns() + timeout_ns_);
    if (!response) {
      ++counters_.timeouts;
      return fail(node, address, SdoStatus::kTimeout, canopen::sdo_abort::kTimeout);
    }
    if (response->kind == SdoResponseKind::kAbort) {
      ++counters_.aborts_received;
      return SdoResult{SdoStatus::kAborted, 0, 0, response->value, {}};
    }
    if (response->kind == SdoResponseKind::kInvalid) {
      ++counters_.malformed_responses;
      return fail(node, address, SdoStatus::kProtocolError, canopen::sdo_abort::kCommandSpecifier);
    }
    if (response->kind != SdoResponseKind::kUploadSegment) {
      ++counters_.unexpected_responses;
      return fail(node, address, SdoStatus::kProtocolError, canopen::sdo_abort::kCommandSpecifier);
    }
    if (response->toggle != toggle) {
      ++counters_.toggle_errors;
      return fail(node, address, SdoStatus::kProtocolError, canopen::sdo_abort::kToggleBit);
    }
    if (result.bytes.size() + response->segment_bytes > kMaxSegmentedBytes) {
      return fail(node, address, SdoStatus::kProtocolError, canopen::sdo_abort::kGeneral);
    }
    result.bytes.insert(result.bytes.end(), response->segment.begin(),
                        response->segment.begin() + response->segment_bytes);
    if (response->last_segment) {
      break;
    }
    toggle = !toggle;
  }
  if (total_size != 0 && result.bytes.size() != total_size) {
    // The indicated size is part of the protocol: a mismatch is a length error.
    result.status = SdoStatus::kProtocolError;
    result.abort_code = canopen::sdo_abort::kLengthMismatch;
    ++counters_.unexpected_responses;
  }
  return result;
}

}  // namespace fl::drivers
