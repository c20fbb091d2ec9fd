// Process I/O and logic doubles shared by the runtime tests. Everything they record in the
// cycle goes into fixed arrays, so they add no allocation of their own.
#pragma once

#include <time.h>

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>

#include "fl/controller/runtime.hpp"
#include "scan_thread_probe.hpp"

namespace fl::test {

inline std::int64_t monotonic_now_ns() {
  timespec now{};
  clock_gettime(CLOCK_MONOTONIC, &now);
  return static_cast<std::int64_t>(now.tv_sec) * 1'000'000'000 + now.tv_nsec;
}

inline void sleep_for_ns(std::int64_t duration_ns) {
  timespec duration{};
  duration.tv_sec = static_cast<time_t>(duration_ns / 1'000'000'000);
  duration.tv_nsec = static_cast<long>(duration_ns % 1'000'000'000);
  while (clock_nanosleep(CLOCK_MONOTONIC, 0, &duration, &duration) != 0) {
  }
}

// Copies a prepared input image in and the output image out, as a driver does with its
// process data, and keeps the scheduled and measured time of every scan.
class CopyingIo final : public ProcessIo {
 public:
  static constexpr std::size_t kMaxRecordedScans = 4096;

  explicit CopyingIo(bool arm_probe = false) : arm_probe_(arm_probe) {}

  void activate() override {
    if (arm_probe_) arm_probe_on_this_thread(true);
    activated_ = true;
  }
  void deactivate() override {
    if (arm_probe_) arm_probe_on_this_thread(false);
    deactivated_ = true;
  }

  void read(std::int64_t now_ns, InputImage& in) override {
    const std::int64_t scheduled_time_ns = in.time_ns;
    in = next_input;
    in.time_ns = now_ns;
    const std::size_t scan = reads_.load(std::memory_order_relaxed);
    if (scan < kMaxRecordedScans) {
      now_ns_[scan] = now_ns;
      preset_time_ns_[scan] = scheduled_time_ns;
      read_at_ns_[scan] = monotonic_now_ns();
    }
    reads_.store(scan + 1, std::memory_order_release);
  }

  void write(const OutputImage& out) override {
    last_output = out;
    writes_.fetch_add(1, std::memory_order_release);
  }

  [[nodiscard]] std::size_t reads() const { return reads_.load(std::memory_order_acquire); }
  [[nodiscard]] std::size_t writes() const { return writes_.load(std::memory_order_acquire); }
  [[nodiscard]] std::size_t recorded() const {
    return reads() < kMaxRecordedScans ? reads() : kMaxRecordedScans;
  }
  // Read after ScanRuntime::wait().
  [[nodiscard]] std::int64_t now_ns(std::size_t scan) const { return now_ns_[scan]; }
  [[nodiscard]] std::int64_t preset_time_ns(std::size_t scan) const {
    return preset_time_ns_[scan];
  }
  [[nodiscard]] std::int64_t read_at_ns(std::size_t scan) const { return read_at_ns_[scan]; }
  [[nodiscard]] bool activated() const { return activated_; }
  [[nodiscard]] bool deactivated() const { return deactivated_; }

  InputImage next_input{};
  OutputImage last_output{};

 private:
  bool arm_probe_;
  bool activated_ = false;
  bool deactivated_ = false;
  std::atomic<std::size_t> reads_{0};
  std::atomic<std::size_t> writes_{0};
  std::array<std::int64_t, kMaxRecordedScans> now_ns_{};
  std::array<std::int64_t, kMaxRecordedScans> preset_time_ns_{};
  std::array<std::int64_t, kMaxRecordedScans> read_at_ns_{};
};

// Writes something that depends on the input, so that the scan is not optimised away.
class EchoLogic : public ScanLogic {
 public:
  void update(const InputImage& in, OutputImage& out) override {
    out.drives[0].enable = in.estop_ok;
    out.drives[0].speed_mps = static_cast<float>(in.time_ns % 1000) * 1e-3F;
    updates_.fetch_add(1, std::memory_order_relaxed);
  }
  [[nodiscard]] std::uint64_t updates() const { return updates_.load(std::memory_order_relaxed); }

 private:
  std::atomic<std::uint64_t> updates_{0};
};

}  // namespace fl::test
