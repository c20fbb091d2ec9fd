// In-process CAN bus for logic tests and the emulated devices: every endpoint receives the
// frames every other endpoint sends (as on a real bus, not its own), in send order, with
// the hub's clock as timestamp. A test double: single-threaded, no arbitration, no error
// frames except those a test injects. Real kernel behaviour is tested over vcan in qemu.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "fl/drivers/can_bus.hpp"

namespace fl::drivers {

class LoopbackHub;

class LoopbackBus final : public CanBus {
 public:
  bool send(const CanFrame& frame) override;
  std::size_t receive(std::span<CanFrame> out) override;
  std::size_t take_send_confirmations(std::span<CanSendConfirmation> out) override {
    return confirmations_.take(out);
  }
  [[nodiscard]] CanErrorState error_state() const override { return error_state_; }
  [[nodiscard]] const CanBusCounters& counters() const override { return counters_; }

  // Test hooks: force the error state; drop everything this endpoint sends (a dead node).
  void set_error_state(CanErrorState state) { error_state_ = state; }
  void set_transmit_enabled(bool enabled) { transmit_enabled_ = enabled; }
  // Confirms every frame this endpoint puts on the hub, stamped with the hub's clock.
  void set_send_confirmations(bool enabled) { confirm_sends_ = enabled; }
  // Puts a frame straight into this endpoint's receive queue (malformed-frame tests).
  void inject(const CanFrame& frame);
  [[nodiscard]] std::size_t pending() const { return count_; }

 private:
  friend class LoopbackHub;
  LoopbackBus(LoopbackHub& hub, std::size_t capacity) : hub_(hub), ring_(capacity) {}
  void deliver(const CanFrame& frame);

  LoopbackHub& hub_;
  std::vector<CanFrame> ring_;  // allocated once; a full ring drops and counts an overrun
  std::size_t head_ = 0;
  std::size_t count_ = 0;
  CanErrorState error_state_ = CanErrorState::kErrorActive;
  bool transmit_enabled_ = true;
  bool confirm_sends_ = false;
  SendConfirmationQueue confirmations_;
  CanBusCounters counters_;
};

class LoopbackHub {
 public:
  // `clock_ns` stamps delivered frames; `capacity` frames fit in each endpoint's queue.
  explicit LoopbackHub(std::function<std::int64_t()> clock_ns, std::size_t capacity = 1024)
      : clock_ns_(std::move(clock_ns)), capacity_(capacity) {}
  LoopbackBus& add_endpoint();
  // Every frame sent on the hub so far, in order (a candump of the loopback bus).
  [[nodiscard]] const std::vector<CanFrame>& trace() const { return trace_; }
  void set_trace_enabled(bool enabled) { trace_enabled_ = enabled; }
  void clear_trace() { trace_.clear(); }

 private:
  friend class LoopbackBus;
  // Returns the stamp the frame was delivered with.
  std::int64_t broadcast(const LoopbackBus& sender, const CanFrame& frame);

  std::function<std::int64_t()> clock_ns_;
  std::size_t capacity_;
  std::vector<std::unique_ptr<LoopbackBus>> endpoints_;
  std::vector<CanFrame> trace_;
  bool trace_enabled_ = false;
};

}  // namespace fl::drivers
