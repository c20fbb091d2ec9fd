// Belt drives: command delay, ramps within the drive limits, encoders.
#include "fl/twin/sensors/drive_emulator.hpp"

#include <algorithm>
#include <cmath>

namespace fl {

DriveEmulator::DriveEmulator(const std::array<DriveLimits, kDriveCount>& limits, double delay_s)
    : limits_(limits), delay_ns_(std::max<std::int64_t>(0, std::llround(delay_s * 1e9))) {
  reset();
}

void DriveEmulator::reset() {
  drives_ = {};
  head_ = 0;
  count_ = 0;
}

void DriveEmulator::command(const std::array<DriveCommand, kDriveCount>& commands,
                            std::int64_t time_ns) {
  head_ = (head_ + 1) % kCommandHistory;
  history_[head_].sent_ns = time_ns;
  history_[head_].commands = commands;
  count_ = std::min(count_ + 1, kCommandHistory);
}

const DriveEmulator::Commands& DriveEmulator::delayed(std::int64_t at_ns) const {
  for (std::size_t i = 0; i < count_; ++i) {
    const std::size_t slot = (head_ + kCommandHistory - i) % kCommandHistory;
    if (history_[slot].sent_ns + delay_ns_ <= at_ns) return history_[slot].commands;
  }
  if (count_ == kCommandHistory) {
    // A delay longer than the history: the oldest command kept is the best there is.
    return history_[(head_ + 1) % kCommandHistory].commands;
  }
  return idle_;
}

void DriveEmulator::step(std::int64_t time_ns, double h_s,
                         const std::array<bool, kDriveCount>& tripped, bool powered) {
  const Commands& commands = delayed(time_ns);
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    DriveState& drive = drives_[d];
    const DriveLimits& limits = limits_[d];
    const DriveCommand& command = commands[d];
    drive.fault = tripped[d];
    const bool enabled = powered && command.enable && !drive.fault;
    const double max_accel_mps2 = limits.max_accel_mps2;
    double target_mps = 0.0;
    // Disabled or tripped: quick-stop ramp at the drive's limit.
    double accel_mps2 = max_accel_mps2;
    if (enabled) {
      const double max_speed_mps = limits.max_speed_mps;
      target_mps =
          std::clamp(static_cast<double>(command.speed_mps), -max_speed_mps, max_speed_mps);
      // A command ramp of zero (or less) means "as fast as allowed".
      if (command.accel_mps2 > 0.0F) {
        accel_mps2 = std::min(static_cast<double>(command.accel_mps2), max_accel_mps2);
      }
    }
    const double old_mps = drive.speed_mps;
    drive.speed_mps = approach(old_mps, target_mps, accel_mps2 * h_s);
    // Trapezoid: exact for the piecewise-linear speed of a ramp.
    drive.position_mm += 0.5 * (old_mps + drive.speed_mps) * h_s * 1000.0;
    drive.encoder_counts =
        static_cast<std::int64_t>(std::floor(drive.position_mm * limits.counts_per_mm));
    drive.ready = enabled;
  }
}

void DriveEmulator::write(std::array<DriveFeedback, kDriveCount>& feedback) const {
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    feedback[d].speed_mps = static_cast<float>(drives_[d].speed_mps);
    feedback[d].encoder_counts = drives_[d].encoder_counts;
    feedback[d].ready = drives_[d].ready;
    feedback[d].fault = drives_[d].fault;
  }
}

}  // namespace fl
