// The transport the CANopen layer runs on: SocketCAN on the line and in the vcan tests, an
// in-process loopback in logic tests. Every call is non-blocking and allocation-free, so
// the CANopen master can use it inside the 10 ms cycle.
#pragma once

#include <cstdint>
#include <span>

#include "fl/drivers/can_frame.hpp"

namespace fl::drivers {

// The controller's fault confinement state as its error frames report it (ISO 11898-1,
// 6.15): error active below 96 errors, warning at 96, passive at 128, bus off at 256 TX errors.
enum class CanErrorState : std::uint8_t { kErrorActive, kErrorWarning, kErrorPassive, kBusOff };
const char* to_string(CanErrorState state);

struct CanBusCounters {
  std::uint64_t frames_sent = 0;
  std::uint64_t frames_received = 0;
  std::uint64_t tx_queue_full = 0;     // send refused because the TX queue is full (ENOBUFS)
  std::uint64_t tx_errors = 0;         // any other send failure
  std::uint64_t rx_errors = 0;         // receive failures other than "nothing pending"
  std::uint64_t rx_overruns = 0;       // frames the receiver dropped (kernel or ring full)
  std::uint64_t error_frames = 0;      // error frames seen
  std::uint64_t bus_off_events = 0;    // transitions into bus off
  std::uint64_t restarts = 0;          // controller restarted after bus off (CAN_ERR_RESTARTED)
  std::uint64_t malformed_frames = 0;  // frames refused by the transport (e.g. DLC > 8)
};

class CanBus {
 public:
  CanBus() = default;
  CanBus(const CanBus&) = delete;
  CanBus& operator=(const CanBus&) = delete;
  virtual ~CanBus() = default;

  // Queues one frame. False when it was not queued (TX queue full, bus off, error): the
  // caller counts on the next cycle's send, it never waits.
  virtual bool send(const CanFrame& frame) = 0;
  // Moves up to out.size() pending frames into `out` and returns how many; 0 when none.
  // Error frames are consumed here (they update error_state()) and not returned.
  virtual std::size_t receive(std::span<CanFrame> out) = 0;

  [[nodiscard]] virtual CanErrorState error_state() const = 0;
  [[nodiscard]] virtual const CanBusCounters& counters() const = 0;
};

}  // namespace fl::drivers
