// A single-producer single-consumer triple buffer: the producer always has a slot to write,
// the consumer always has a consistent slot to read, and handing over is one atomic
// exchange on each side. Wait-free, no lock, no allocation: the scan thread can read the
// newest value while another thread writes the next one.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>

namespace fl::drivers::dds {

template <class T>
class TripleBuffer {
 public:
  // Producer: fill back(), then publish().
  T& back() noexcept { return slots_[back_]; }
  void publish() noexcept {
    back_ = static_cast<std::uint8_t>(
        middle_.exchange(static_cast<std::uint8_t>(back_ | kFresh), std::memory_order_acq_rel) &
        kIndexMask);
  }

  // Consumer: true when a newer value was published since the last call; front() then holds
  // it. front() keeps the last value otherwise.
  bool update() noexcept {
    if ((middle_.load(std::memory_order_relaxed) & kFresh) == 0) return false;
    front_ =
        static_cast<std::uint8_t>(middle_.exchange(front_, std::memory_order_acq_rel) & kIndexMask);
    return true;
  }
  [[nodiscard]] const T& front() const noexcept { return slots_[front_]; }

 private:
  static constexpr std::uint8_t kIndexMask = 0x3;
  static constexpr std::uint8_t kFresh = 0x4;
  std::array<T, 3> slots_{};
  std::uint8_t back_ = 0;   // producer's own
  std::uint8_t front_ = 1;  // consumer's own
  std::atomic<std::uint8_t> middle_{2};
};

}  // namespace fl::drivers::dds
