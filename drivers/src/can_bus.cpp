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

namespace {

bool same_frame(const CanFrame& a, const CanFrame& b) {
  return a.id == b.id && a.extended == b.extended && a.remote == b.remote && a.dlc == b.dlc &&
         a.data == b.data;
}

}  // namespace

void SendConfirmationQueue::record_send(const CanFrame& frame, std::int64_t queued_ns,
                                        CanBusCounters& counters) {
  if (sent_count_ == kCapacity) {
    sent_head_ = (sent_head_ + 1) % kCapacity;
    --sent_count_;
    ++counters.sends_unconfirmed;
  }
  sent_[(sent_head_ + sent_count_) % kCapacity] = SentRecord{frame, queued_ns};
  ++sent_count_;
}

bool SendConfirmationQueue::confirm(const CanFrame& echo, std::int64_t sent_ns,
                                    CanBusCounters& counters) {
  std::size_t match = 0;
  while (match < sent_count_ && !same_frame(sent_[(sent_head_ + match) % kCapacity].frame, echo)) {
    ++match;
  }
  if (match == sent_count_) {
    return false;
  }
  const std::int64_t queued_ns = sent_[(sent_head_ + match) % kCapacity].queued_ns;
  // Close the gap: the records before the match move up one place (usually none do).
  for (std::size_t i = match; i > 0; --i) {
    sent_[(sent_head_ + i) % kCapacity] = sent_[(sent_head_ + i - 1) % kCapacity];
  }
  sent_head_ = (sent_head_ + 1) % kCapacity;
  --sent_count_;
  ++counters.sends_confirmed;
  if (confirmed_count_ == kCapacity) {
    ++counters.confirmations_dropped;  // the newest is dropped, as a full receive queue does
    return true;
  }
  confirmed_[(confirmed_head_ + confirmed_count_) % kCapacity] =
      CanSendConfirmation{echo.id, queued_ns, sent_ns};
  ++confirmed_count_;
  return true;
}

std::size_t SendConfirmationQueue::take(std::span<CanSendConfirmation> out) {
  std::size_t count = 0;
  while (count < out.size() && confirmed_count_ > 0) {
    out[count++] = confirmed_[confirmed_head_];
    confirmed_head_ = (confirmed_head_ + 1) % kCapacity;
    --confirmed_count_;
  }
  return count;
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
    const std::int64_t sent_ns = hub_.broadcast(*this, frame);
    if (confirm_sends_) {
      // No arbitration or queue here: the frame is on the "bus" the moment it is sent.
      confirmations_.record_send(frame, sent_ns, counters_);
      confirmations_.confirm(frame, sent_ns, counters_);
    }
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

std::int64_t LoopbackHub::broadcast(const LoopbackBus& sender, const CanFrame& frame) {
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
  return stamped.timestamp_ns;
}

}  // namespace fl::drivers
