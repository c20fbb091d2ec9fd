// The line's belt drives as both plants emulate them: a command reaches the frequency
// controller after the drive delay (thesis 5.3: about 5 ms), the belt ramps to the commanded
// speed within the drive's speed and acceleration limits (a disabled, tripped or unpowered
// drive quick-stops at its limit), and the encoder counts the integrated surface travel.
// The plants read the belt speeds from here to move their bodies; the emulator writes
// InputImage::drives. Nothing here allocates or draws random numbers.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>

#include "fl/controller/line_config.hpp"
#include "fl/controller/process_image.hpp"

namespace fl {

// Moves `value` towards `target` by at most `max_step`: one step of a ramp, for the belts here
// and for the station actuators of both plants.
inline double approach(double value, double target, double max_step) {
  if (value < target) return std::min(value + max_step, target);
  return std::max(value - max_step, target);
}

struct DriveState {
  double speed_mps = 0.0;
  double position_mm = 0.0;  // integrated belt travel, the encoder's source
  std::int64_t encoder_counts = 0;
  bool ready = false;
  bool fault = false;
};

class DriveEmulator {
 public:
  DriveEmulator(const std::array<DriveLimits, kDriveCount>& limits, double delay_s);

  // Belts at rest, encoders at 0, no command received.
  void reset();

  // The controller's commands as they leave it at time_ns; they act drive_delay later.
  void command(const std::array<DriveCommand, kDriveCount>& commands, std::int64_t time_ns);

  // Advances every drive by h_s from time_ns under the command in force at time_ns.
  // tripped: drive faults (not ready, fault, quick stop); powered false: the safety chain is
  // open (STO): every drive stops and reports not ready.
  void step(std::int64_t time_ns, double h_s, const std::array<bool, kDriveCount>& tripped,
            bool powered);

  [[nodiscard]] double speed_mps(DriveId drive) const { return drives_[index(drive)].speed_mps; }
  [[nodiscard]] const DriveState& drive(DriveId drive) const { return drives_[index(drive)]; }
  [[nodiscard]] std::int64_t delay_ns() const { return delay_ns_; }

  // Speed, encoder, ready and fault of every drive into the input image.
  void write(std::array<DriveFeedback, kDriveCount>& feedback) const;

 private:
  using Commands = std::array<DriveCommand, kDriveCount>;
  // The command in force at at_ns: the newest that has arrived by then.
  [[nodiscard]] const Commands& delayed(std::int64_t at_ns) const;

  // 16 scans of history cover delays up to 160 ms at the 10 ms scan.
  static constexpr std::size_t kCommandHistory = 16;
  struct TimedCommands {
    std::int64_t sent_ns = 0;
    Commands commands{};
  };

  std::array<DriveLimits, kDriveCount> limits_;
  std::int64_t delay_ns_;
  std::array<DriveState, kDriveCount> drives_{};
  std::array<TimedCommands, kCommandHistory> history_{};
  std::size_t head_ = 0;  // newest entry
  std::size_t count_ = 0;
  Commands idle_{};  // before the first command: everything disabled
};

}  // namespace fl
