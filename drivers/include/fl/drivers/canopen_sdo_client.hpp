// SDO client for start-up configuration, outside the real-time cycle: expedited download
// and upload (1..4 bytes), segmented upload (strings such as 0x1008), abort codes decoded,
// a timeout per response. Blocking: it waits through a BusClock, which sleeps on the real
// bus and steps the emulated devices in tests.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "fl/drivers/can_bus.hpp"
#include "fl/drivers/canopen.hpp"

namespace fl::drivers {

struct BusClock {
  std::function<std::int64_t()> now_ns;
  // Lets `duration_ns` pass.
  std::function<void(std::int64_t duration_ns)> wait_ns;
};
// CLOCK_MONOTONIC and nanosleep.
BusClock monotonic_bus_clock();

enum class SdoStatus : std::uint8_t {
  kOk,
  kAborted,        // the server aborted: abort_code says why
  kTimeout,        // no response within the timeout (the client sent abort 0x05040000)
  kProtocolError,  // malformed or unexpected response, wrong toggle (the client aborted)
  kSendFailed,     // the request could not be queued
};
const char* to_string(SdoStatus status);

struct SdoResult {
  SdoStatus status = SdoStatus::kOk;
  std::uint32_t value = 0;          // expedited upload
  std::uint8_t size_bytes = 0;      // expedited upload
  std::uint32_t abort_code = 0;     // kAborted: the server's; kTimeout/kProtocolError: ours
  std::vector<std::uint8_t> bytes;  // segmented upload
  [[nodiscard]] bool ok() const { return status == SdoStatus::kOk; }
  // "aborted: 0x06020000 object does not exist in the object dictionary"
  [[nodiscard]] std::string describe() const;
};

struct SdoClientCounters {
  std::uint64_t transfers = 0;
  std::uint64_t timeouts = 0;
  std::uint64_t aborts_received = 0;
  std::uint64_t malformed_responses = 0;   // wrong DLC or unknown command specifier
  std::uint64_t unexpected_responses = 0;  // valid frame, wrong for this transfer
  std::uint64_t toggle_errors = 0;
};

class SdoClient {
 public:
  // `other_frames` receives every frame that is not this transfer's response (heartbeats,
  // EMCY during start-up), so that nothing is lost while the client owns the bus.
  SdoClient(CanBus& bus, BusClock clock, std::int64_t timeout_ns,
            std::function<void(const CanFrame&)> other_frames = {});

  SdoResult download(canopen::NodeId node, canopen::SdoAddress address, std::uint32_t value,
                     std::uint8_t size_bytes);
  SdoResult upload(canopen::NodeId node, canopen::SdoAddress address);

  [[nodiscard]] const SdoClientCounters& counters() const { return counters_; }
  // Longest segmented upload accepted (a broken server must not fill the memory).
  static constexpr std::size_t kMaxSegmentedBytes = 1024;
  // How long one wait step lets pass while polling for a response.
  static constexpr std::int64_t kPollStepNs = 100'000;

 private:
  // The next response from `node`, or nothing by the deadline.
  std::optional<canopen::SdoResponse> await_response(canopen::NodeId node,
                                                     std::int64_t deadline_ns);
  SdoResult fail(canopen::NodeId node, canopen::SdoAddress address, SdoStatus status,
                 std::uint32_t abort_code);

  CanBus& bus_;
  BusClock clock_;
  std::int64_t timeout_ns_;
  std::function<void(const CanFrame&)> other_frames_;
  std::array<CanFrame, 32> batch_{};
  std::size_t batch_size_ = 0;
  std::size_t batch_next_ = 0;
  SdoClientCounters counters_;
};

}  // namespace fl::drivers
