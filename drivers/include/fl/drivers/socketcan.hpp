// SocketCAN transport: one raw CAN_RAW socket bound to one interface (can0 on the line,
// vcan0 in tests), non-blocking, with kernel receive timestamps (SO_TIMESTAMPNS) and error
// frames (CAN_RAW_ERR_FILTER) from which it tracks the controller's error state.
//
// Send timestamps: with `confirm_sends` the socket receives its own frames back
// (CAN_RAW_RECV_OWN_MSGS). The kernel marks them MSG_CONFIRM and stamps them when the driver
// echoes them, which a real CAN driver does once the controller reports the frame sent; so
// the stamp is when the frame left, and the gap to send() is the queueing and arbitration
// delay. receive() turns those echoes into CanSendConfirmations instead of frames. The echo
// passes the receive filters like any frame: a filtered-out id is never confirmed.
//
// Bus off and restart: the kernel's CAN driver, not this process, restarts a controller
// after bus off, either automatically (`ip link set can0 type can bitrate 1000000
// restart-ms 100`) or by hand (`ip link set can0 type can restart`). This class reports
// bus off (error_state() == kBusOff, counters().bus_off_events) as soon as the error frame
// arrives and refuses to send while off; the CAN_ERR_RESTARTED error frame the driver sends
// after the restart brings it back to error active (counters().restarts). That frame can be
// lost (a full receive queue drops error frames too), and a bus that waited for it would
// refuse to send for good: so while off, send() asks the kernel every kBusOffProbeNs whether
// the interface is running again (IFF_RUNNING: can-dev drops the carrier at bus off and
// raises it at the restart) and, if so, takes the restart as done
// (counters().restarts_inferred). vcan has no controller and never reports any of this; the
// tests inject error frames instead.
//
// The only place of the project that touches sockets.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "fl/drivers/can_bus.hpp"

namespace fl::drivers {

struct SocketCanOptions {
  std::string interface_name = "vcan0";
  // Receive filters (id, mask), CAN_RAW_FILTER semantics; empty: receive every frame.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> filters;
  bool receive_error_frames = true;  // CAN_RAW_ERR_FILTER with every error class
  bool receive_own_frames = false;   // CAN_RAW_RECV_OWN_MSGS (tests only)
  int receive_buffer_bytes = 0;      // SO_RCVBUF; 0 leaves the kernel default
  bool confirm_sends = false;        // own frames come back as send confirmations
};

// Thrown by the constructor (outside the cycle) with the failing call and errno text.
class SocketCanError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class SocketCanBus final : public CanBus {
 public:
  // How often a bus-off socket asks whether its interface runs again (can.yaml's restart-ms is
  // 100 ms: the restart is due by then).
  static constexpr std::int64_t kBusOffProbeNs = 100'000'000;

  explicit SocketCanBus(const SocketCanOptions& options);
  ~SocketCanBus() override;

  bool send(const CanFrame& frame) override;
  std::size_t receive(std::span<CanFrame> out) override;
  std::size_t take_send_confirmations(std::span<CanSendConfirmation> out) override {
    return confirmations_.take(out);
  }
  [[nodiscard]] CanErrorState error_state() const override { return error_state_; }
  [[nodiscard]] const CanBusCounters& counters() const override { return counters_; }

  [[nodiscard]] const std::string& interface_name() const { return interface_name_; }
  [[nodiscard]] int native_handle() const { return socket_fd_; }

  // Decodes one error frame into the new error state (exposed for tests: vcan never makes
  // error frames). `class_bits` is can_id without CAN_ERR_FLAG, `data` its 8 bytes.
  static CanErrorState next_error_state(CanErrorState current, std::uint32_t class_bits,
                                        const std::array<std::uint8_t, kCanMaxDataBytes>& data);
  // Applies an error frame as receive() does (counts, bus-off and restart transitions).
  void apply_error_frame(std::uint32_t class_bits,
                         const std::array<std::uint8_t, kCanMaxDataBytes>& data);

 private:
  std::string interface_name_;
  int socket_fd_ = -1;
  bool confirm_sends_ = false;
  CanErrorState error_state_ = CanErrorState::kErrorActive;
  std::int64_t bus_off_probe_ns_ = 0;  // CLOCK_MONOTONIC of the next interface probe
  [[nodiscard]] bool interface_running() const;
  SendConfirmationQueue confirmations_;
  CanBusCounters counters_;
};

}  // namespace fl::drivers
