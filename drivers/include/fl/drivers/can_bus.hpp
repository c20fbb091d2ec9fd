// The transport the CANopen layer runs on: SocketCAN on the line and in the vcan tests, an
// in-process loopback in logic tests. Every call is non-blocking and allocation-free, so
// the CANopen master can use it inside the 10 ms cycle.
#pragma once

#include <array>
#include <cstddef>
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
  std::uint64_t tx_queue_full = 0;   // send refused because the TX queue is full (ENOBUFS)
  std::uint64_t tx_errors = 0;       // any other send failure
  std::uint64_t rx_errors = 0;       // receive failures other than "nothing pending"
  std::uint64_t rx_overruns = 0;     // frames the receiver dropped (kernel or ring full)
  std::uint64_t error_frames = 0;    // error frames seen
  std::uint64_t bus_off_events = 0;  // transitions into bus off
  std::uint64_t restarts = 0;        // controller restarted after bus off (CAN_ERR_RESTARTED)
  // Back from bus off without the restart error frame (it was lost): the interface's carrier
  // was seen up again (SocketCAN only).
  std::uint64_t restarts_inferred = 0;
  std::uint64_t malformed_frames = 0;  // frames refused by the transport (e.g. DLC > 8)
  // Send confirmations (only where the transport has them switched on):
  std::uint64_t sends_confirmed = 0;        // own frames seen back on the bus, stamped
  std::uint64_t sends_unconfirmed = 0;      // no confirmation before the record was evicted
  std::uint64_t confirmations_dropped = 0;  // confirmation queue full: nobody takes them
};

// A frame this endpoint sent, confirmed as transmitted. On SocketCAN this is the echo of the
// socket's own frame (MSG_CONFIRM): a real CAN driver echoes a frame when its controller
// reports it sent (IFF_ECHO), so `sent_ns` is when it left; vcan echoes it as it is queued.
struct CanSendConfirmation {
  std::uint32_t id = 0;
  std::int64_t queued_ns = 0;  // when send() queued it
  std::int64_t sent_ns = 0;    // the transport's stamp of the transmission
};

// The bookkeeping behind send confirmations, shared by the transports: a record of each
// frame sent, matched with its echo when that comes back, and the matched pairs queued until
// taken. Fixed capacity, no allocation: a transport uses it inside the cycle.
class SendConfirmationQueue {
 public:
  static constexpr std::size_t kCapacity = 256;  // more than ten cycles of the line's traffic

  // A frame was queued at `queued_ns`. A full record evicts its oldest entry, counted as
  // unconfirmed (an echo lost with a bus off, or a driver that never echoes).
  void record_send(const CanFrame& frame, std::int64_t queued_ns, CanBusCounters& counters);
  // An echo of an own frame arrived, stamped `sent_ns`. Matches the oldest record of the same
  // frame (id, flags, data): a controller with several TX buffers may send out of order.
  // False when no record matches.
  bool confirm(const CanFrame& echo, std::int64_t sent_ns, CanBusCounters& counters);
  std::size_t take(std::span<CanSendConfirmation> out);

 private:
  struct SentRecord {
    CanFrame frame;
    std::int64_t queued_ns = 0;
  };
  std::array<SentRecord, kCapacity> sent_{};
  std::size_t sent_head_ = 0;
  std::size_t sent_count_ = 0;
  std::array<CanSendConfirmation, kCapacity> confirmed_{};
  std::size_t confirmed_head_ = 0;
  std::size_t confirmed_count_ = 0;
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

  // Moves up to out.size() send confirmations, oldest first, and returns how many. They are
  // collected by receive(), so take them after it. Transports without confirmations (or
  // with them off) return 0.
  virtual std::size_t take_send_confirmations(std::span<CanSendConfirmation> out) {
    (void)out;
    return 0;
  }

  [[nodiscard]] virtual CanErrorState error_state() const = 0;
  [[nodiscard]] virtual const CanBusCounters& counters() const = 0;
};

}  // namespace fl::drivers
