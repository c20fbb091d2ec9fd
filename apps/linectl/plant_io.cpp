#include "plant_io.hpp"

namespace fl::apps {

PlantIo::PlantIo(Plant& plant, std::uint64_t seed) : plant_(plant) {
  plant_.reset(seed, plant_input_);
}

void PlantIo::read(std::int64_t now_ns, InputImage& in) {
  if (plant_time_offset_ns_ < 0) {
    plant_time_offset_ns_ = now_ns - plant_input_.time_ns;
    last_now_ns_ = now_ns;
  }
  // Skipped periods after an overrun advance the plant by the whole gap, as the real line
  // would have moved on.
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
