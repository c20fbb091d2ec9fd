#include "fl/drivers/can_bus.hpp"

#include "fl/drivers/loopback_bus.hpp"

namespace fl::drivers {

const char* to_string(CanErrorState state) {
  switch (state) {
    case CanErrorState::kErrorActive:
      return "error active";
    case CanErrorState::kErrorWarning:
      return "error warning";
    case CanErrorState::kErrorPassive:
      return "error passive";
    case CanErrorState::kBusOff:
      return "bus off";
  }
  return "unknown";
}

bool LoopbackBus::send(const CanFrame& frame) {
  if (error_state_ == CanErrorState::kBusOff) {
    ++counters_.tx_errors;
    return false;
  }
  if (frame.dlc > kCanMaxDataBytes || frame.error) {
    ++counters_.malformed_frames;
    return false;
  }
  ++counters_.frames_sent;
  if (transmit_enabled_) {
    hub_.broadcast(*this, frame);
  }
  return true;
}

std::size_t LoopbackBus::receive(std::span<CanFrame> out) {
  std::size_t count = 0;
  while (count < out.size() && count_ > 0) {
    out[count++] = ring_[head_];
    head_ = (head_ + 1) % ring_.size();
    --count_;
  }
  counters_.frames_received += count;
  return count;
}

void LoopbackBus::inject(const CanFrame& frame) { deliver(frame); }

void LoopbackBus::deliver(const CanFrame& frame) {
  if (count_ == ring_.size()) {
    ++counters_.rx_overruns;  // like the kernel's full socket queue: the newest is dropped
    return;
  }
  ring_[(head_ + count_) % ring_.size()] = frame;
  ++count_;
}

LoopbackBus& LoopbackHub::add_endpoint() {
  endpoints_.push_back(std::unique_ptr<LoopbackBus>(new LoopbackBus(*this, capacity_)));
  return *endpoints_.back();
}

void LoopbackHub::broadcast(const LoopbackBus& sender, const CanFrame& frame) {
  CanFrame stamped = frame;
  stamped.timestamp_ns = clock_ns_();
  if (trace_enabled_) {
    trace_.push_back(stamped);
  }
  for (const auto& endpoint : endpoints_) {
    if (endpoint.get() != &sender) {
      endpoint->deliver(stamped);
    }
  }
}

}  // namespace fl::drivers
