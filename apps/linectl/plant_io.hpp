// A plant behind the real-time runtime: each scan advances the plant to the scan's
// scheduled time and passes the images through, so the same logic that runs in lock step
// runs in real time against the same plant.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>

#include "fl/controller/ledger.hpp"
#include "fl/controller/plant.hpp"
#include "fl/controller/runtime.hpp"

namespace fl {
struct FastPlantFaults;
struct DemPlantFaults;
}  // namespace fl

namespace fl::apps {

// Faults raised in the twin while it runs behind the runtime (the HMI's twin panel, the HMI's
// end-to-end test): the same switches the closed-loop scenarios set between steps.
enum class TwinFault : std::uint8_t {
  kCameraSilent,      // target: a camera; it stops delivering frames
  kDriveLost,         // target: a drive; it trips (not ready, fault, stops)
  kEstopOpen,         // the safety chain opens
  kLevellerOverload,  // the leveller's overload switch (fast plant only)
};

class PlantIo final : public ProcessIo {
 public:
  // `switches`: the plant whose fault switches set_twin_fault() drives, when `plant` wraps
  // it (a CanopenPlant around the fast plant: the fault then reaches the controller through
  // the bus, as the real one would); null: `plant` itself.
  PlantIo(Plant& plant, std::uint64_t seed, Plant* switches = nullptr);

  void read(std::int64_t now_ns, InputImage& in) override;
  void write(const OutputImage& out) override { output_ = out; }

  // Ground-truth exits for the non-real-time side; drained there, pushed in read().
  FixedRing<TrueFilletExit, 1024>& exits() { return exits_; }
  // Time of the newest scan; read it after the runtime has stopped.
  [[nodiscard]] std::int64_t last_scan_time_ns() const { return last_now_ns_; }
  // Operator requests, as the HMI's start and stop buttons would give them; any thread.
  void request_line_start() { start_request_.store(true); }
  void request_line_stop() { stop_request_.store(true); }
  // Raises or clears a twin fault from any thread; the scan applies it before its next plant
  // step. `target` is the CameraId or DriveId index where the fault has one. Throws
  // std::invalid_argument for a target out of range or a fault this plant cannot raise.
  void set_twin_fault(TwinFault fault, std::size_t target, bool active);
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
  // Requested twin faults, one bit each (bit layout in plant_io.cpp), and the set the plant
  // has (scan thread only).
  std::atomic<std::uint64_t> requested_faults_{0};
  std::uint64_t applied_faults_ = 0;
  FastPlantFaults* fast_faults_ = nullptr;  // the plant's own switches, when it has them
  DemPlantFaults* dem_faults_ = nullptr;
  std::atomic<bool> start_request_{false};
  std::atomic<bool> stop_request_{false};
};

}  // namespace fl::apps
