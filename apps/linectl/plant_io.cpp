#include "plant_io.hpp"

#include <stdexcept>

#include "fl/twin/dem_plant/dem_plant.hpp"
#include "fl/twin/fast_plant.hpp"

namespace fl::apps {
namespace {

// Bit layout of the requested twin faults: one bit per camera, per drive, and the two
// line-wide switches.
constexpr std::uint64_t kCameraBit0 = 0;
constexpr std::uint64_t kDriveBit0 = 8;
constexpr std::uint64_t kEstopBit = std::uint64_t{1} << 32;
constexpr std::uint64_t kLevellerBit = std::uint64_t{1} << 33;
static_assert(kCameraCount <= kDriveBit0 - kCameraBit0 && kDriveBit0 + kDriveCount <= 32);

std::uint64_t camera_bit(std::size_t camera) { return std::uint64_t{1} << (kCameraBit0 + camera); }
std::uint64_t drive_bit(std::size_t drive) { return std::uint64_t{1} << (kDriveBit0 + drive); }

template <typename Faults>
void apply_common(std::uint64_t requested, Faults& faults) {
  for (std::size_t c = 0; c < kCameraCount; ++c) {
    faults.cameras[c].stale = (requested & camera_bit(c)) != 0;
  }
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    faults.drive_fault[d] = (requested & drive_bit(d)) != 0;
  }
  faults.estop_open = (requested & kEstopBit) != 0;
}

}  // namespace

PlantIo::PlantIo(Plant& plant, std::uint64_t seed, Plant* switches) : plant_(plant) {
  plant_.reset(seed, plant_input_);
  Plant& faulted = switches != nullptr ? *switches : plant;
  if (auto* fast = dynamic_cast<FastPlant*>(&faulted)) fast_faults_ = &fast->faults();
  if (auto* dem = dynamic_cast<DemPlant*>(&faulted)) dem_faults_ = &dem->faults();
}

void PlantIo::set_twin_fault(TwinFault fault, std::size_t target, bool active) {
  std::uint64_t bit = 0;
  switch (fault) {
    case TwinFault::kCameraSilent:
      if (target >= kCameraCount) throw std::invalid_argument("no camera with that index");
      bit = camera_bit(target);
      break;
    case TwinFault::kDriveLost:
      if (target >= kDriveCount) throw std::invalid_argument("no drive with that index");
      bit = drive_bit(target);
      break;
    case TwinFault::kEstopOpen:
      bit = kEstopBit;
      break;
    case TwinFault::kLevellerOverload:
      if (fast_faults_ == nullptr) {
        throw std::invalid_argument("this plant has no leveller overload switch (fast plant only)");
      }
      bit = kLevellerBit;
      break;
  }
  if (fast_faults_ == nullptr && dem_faults_ == nullptr) {
    throw std::invalid_argument("this plant has no fault injection");
  }
  if (active) {
    requested_faults_.fetch_or(bit, std::memory_order_relaxed);
  } else {
    requested_faults_.fetch_and(~bit, std::memory_order_relaxed);
  }
}

void PlantIo::read(std::int64_t now_ns, InputImage& in) {
  if (plant_time_offset_ns_ < 0) {
    plant_time_offset_ns_ = now_ns - plant_input_.time_ns;
    last_now_ns_ = now_ns;
  }
  // Skipped periods after an overrun advance the plant by the whole gap, as the real line
  // would have moved on.
  const std::uint64_t requested = requested_faults_.load(std::memory_order_relaxed);
  if (requested != applied_faults_) {
    if (fast_faults_ != nullptr) {
      apply_common(requested, *fast_faults_);
      fast_faults_->leveller_overload = (requested & kLevellerBit) != 0;
    } else if (dem_faults_ != nullptr) {
      apply_common(requested, *dem_faults_);
    }
    applied_faults_ = requested;
  }
  const std::int64_t dt_ns = now_ns - last_now_ns_;
  if (dt_ns > 0) plant_.step(output_, dt_ns, plant_input_);
  last_now_ns_ = now_ns;
  for (const TrueFilletExit& exit : plant_.drain_exits()) exits_.push(exit);
  fed_.store(plant_.fillets_fed(), std::memory_order_relaxed);
  on_line_.store(plant_.fillets_on_line(), std::memory_order_relaxed);
  in = plant_input_;
  in.time_ns = now_ns;  // the logic runs on the runtime's clock
  // Frame times come from the plant's clock: move them onto the runtime's.
  for (CameraFrame& frame : in.cameras) frame.frame_time_ns += plant_time_offset_ns_;
  in.start_request = start_request_.exchange(false, std::memory_order_relaxed);
  in.stop_request = stop_request_.exchange(false, std::memory_order_relaxed);
}

}  // namespace fl::apps
