// A plant behind the real-time runtime: each scan advances the plant to the scan's
// scheduled time and passes the images through, so the same logic that runs in lock step
// runs in real time against the same plant.
#pragma once

#include <atomic>
#include <memory>

#include "fl/controller/ledger.hpp"
#include "fl/controller/plant.hpp"
#include "fl/controller/runtime.hpp"

namespace fl::apps {

class PlantIo final : public ProcessIo {
 public:
  PlantIo(Plant& plant, std::uint64_t seed);

  void read(std::int64_t now_ns, InputImage& in) override;
  void write(const OutputImage& out) override { output_ = out; }

  // Ground-truth exits for the non-real-time side; drained there, pushed in read().
  FixedRing<TrueFilletExit, 1024>& exits() { return exits_; }
  // Time of the newest scan; read it after the runtime has stopped.
  [[nodiscard]] std::int64_t last_scan_time_ns() const { return last_now_ns_; }
  // Operator requests, as the HMI's start and stop buttons would give them; any thread.
  void request_line_start() { start_request_.store(true); }
  void request_line_stop() { stop_request_.store(true); }
  [[nodiscard]] std::uint64_t fillets_fed() const { return fed_.load(std::memory_order_relaxed); }
  [[nodiscard]] std::uint64_t fillets_on_line() const {
    return on_line_.load(std::memory_order_relaxed);
  }

 private:
  Plant& plant_;
  InputImage plant_input_{};
  OutputImage output_{};
  std::int64_t plant_time_offset_ns_ = -1;  // runtime clock minus plant clock
  std::int64_t last_now_ns_ = 0;
  FixedRing<TrueFilletExit, 1024> exits_;
  std::atomic<std::uint64_t> fed_{0};
  std::atomic<std::uint64_t> on_line_{0};
  std::atomic<bool> start_request_{false};
  std::atomic<bool> stop_request_{false};
};

}  // namespace fl::apps
