#include "fl/drivers/line_devices.hpp"

#include <cmath>
#include <stdexcept>

#include "line_signals.hpp"

namespace fl::drivers::emulation {

using namespace line_signals;  // NOLINT(google-build-using-namespace): the channel table

LineDevices::LineDevices(CanBus& bus, const CanConfig& config) : config_(config), nodes_(bus) {
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    const DriveNodeConfig& node = config_.drives[d];
    // Position counts per velocity unit and second: counts/mm * mm/m / (units per m/s).
    drives_[d] = &nodes_.add_drive(
        node.node_id, node.position_counts_per_mm * 1000.0 / node.velocity_units_per_mps);
    // The plant moves the belt; the drive reports what the plant measured.
    drives_[d]->set_plant([this, d](DriveState& state, double /*dt_s*/) {
      const DriveFeedback& feedback = plant_.drives[d];
      const double units =
          static_cast<double>(feedback.speed_mps) * config_.drives[d].velocity_units_per_mps;
      state.velocity_actual = static_cast<std::int32_t>(std::llround(units));
      state.position_actual = feedback.encoder_counts;
    });
  }
  for (std::size_t m = 0; m < kIoModuleCount; ++m) {
    modules_[m] = &nodes_.add_io(config_.io_modules[m].node_id);
  }
}

OutputImage LineDevices::commands() const {
  OutputImage out{};
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    const DriveState& state = drives_[d]->state();
    const DriveNodeConfig& node = config_.drives[d];
    DriveCommand& command = out.drives[d];
    command.enable = state.state == cia402::State::kOperationEnabled;
    command.speed_mps = command.enable
                            ? static_cast<float>(static_cast<double>(state.target_velocity) /
                                                 node.velocity_units_per_mps)
                            : 0.0F;
    command.accel_mps2 = static_cast<float>(static_cast<double>(state.acceleration) /
                                            node.acceleration_units_per_mps2);
  }
  const IoScaling& scaling = config_.io_scaling;
  const IoState& infeed = modules_[index(IoModuleId::kInfeed)]->state();
  out.hopper_opening_mm = from_analog_counts(infeed.analog_outputs[infeed_io::kHopperOpeningOut],
                                             scaling.hopper_opening_mm_per_count);
  out.leveller_speed_rpm = from_analog_counts(infeed.analog_outputs[infeed_io::kLevellerSpeedOut],
                                              scaling.leveller_rpm_per_count);
  const IoState& stations = modules_[index(IoModuleId::kStations)]->state();
  out.flip_plate1_flip = (stations.digital_outputs & stations_io::kPlate1FlipOut) != 0;
  out.flip_plate2_flip = (stations.digital_outputs & stations_io::kPlate2FlipOut) != 0;
  out.centring_stroke = (stations.digital_outputs & stations_io::kCentringStrokeOut) != 0;
  out.squeeze_roller_down = (stations.digital_outputs & stations_io::kSqueezeDownOut) != 0;
  out.final_reject = (stations.digital_outputs & stations_io::kFinalRejectOut) != 0;
  out.centring_shift_mm = from_analog_counts(
      stations.analog_outputs[stations_io::kCentringShiftOut], scaling.centring_mm_per_count);
  // The lamps are all the safety module learns of the line's state.
  const IoState& safety = modules_[index(IoModuleId::kSafety)]->state();
  out.state = (safety.digital_outputs & safety_io::kFaultLampOut) != 0     ? LineState::kFault
              : (safety.digital_outputs & safety_io::kRunningLampOut) != 0 ? LineState::kRunning
                                                                           : LineState::kStopped;
  return out;
}

void LineDevices::set_plant_state(const InputImage& plant) {
  plant_ = plant;
  // A fault the plant reports trips the drive, and trips it again after a fault reset for as
  // long as the plant still reports it (a real drive's fault returns while its cause stays).
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    const cia402::State state = drives_[d]->state().state;
    const bool tripped =
        state == cia402::State::kFault || state == cia402::State::kFaultReactionActive;
    if (plant.drives[d].fault && !tripped) drives_[d]->inject_fault(kPlantDriveFaultCode);
  }
  const IoScaling& scaling = config_.io_scaling;
  IoState& infeed = modules_[index(IoModuleId::kInfeed)]->state();
  infeed.digital_inputs =
      static_cast<std::uint8_t>((plant.takt_beam_broken ? infeed_io::kBeamBrokenBit : 0) |
                                (plant.leveller_overload ? infeed_io::kLevellerOverloadBit : 0));
  infeed.analog_inputs[infeed_io::kLevelChannel] =
      to_analog_counts(plant.level_mm, scaling.level_mm_per_count);
  infeed.analog_inputs[infeed_io::kHopperOpeningChannel] =
      to_analog_counts(plant.hopper_opening_mm, scaling.hopper_opening_mm_per_count);
  infeed.analog_inputs[infeed_io::kLevellerSpeedChannel] =
      to_analog_counts(plant.leveller_speed_rpm, scaling.leveller_rpm_per_count);
  IoState& stations = modules_[index(IoModuleId::kStations)]->state();
  stations.digital_inputs =
      static_cast<std::uint8_t>((plant.flip_plate1_flipping ? stations_io::kPlate1FlippingBit : 0) |
                                (plant.flip_plate2_flipping ? stations_io::kPlate2FlippingBit : 0) |
                                (plant.squeeze_roller_down ? stations_io::kSqueezeDownBit : 0));
  stations.analog_inputs[stations_io::kCentringPositionChannel] =
      to_analog_counts(plant.centring_position_mm, scaling.centring_mm_per_count);
  IoState& safety = modules_[index(IoModuleId::kSafety)]->state();
  safety.digital_inputs =
      static_cast<std::uint8_t>((plant.estop_ok ? safety_io::kEstopChainClosedBit : 0) |
                                (plant.start_request ? safety_io::kStartBit : 0) |
                                (plant.stop_request ? safety_io::kStopBit : 0) |
                                (plant.fault_reset_request ? safety_io::kFaultResetBit : 0));
}

}  // namespace fl::drivers::emulation

namespace fl::drivers {

CanopenPlant::CanopenPlant(Plant& inner, const CanConfig& config)
    : inner_(inner), config_(config), name_(std::string(inner.name()) + "+canopen") {}

void CanopenPlant::advance(std::int64_t duration_ns) {
  const std::int64_t end_ns = bus_now_ns_ + duration_ns;
  while (bus_now_ns_ < end_ns) {
    bus_now_ns_ = std::min(end_ns, bus_now_ns_ + kBusStepNs);
    devices_->poll(bus_now_ns_);
  }
}

void CanopenPlant::read_into(InputImage& in) {
  master_->read(bus_now_ns_, in);
  // Not on the bus: the plant's clock and the cameras (DDS on the line).
  in.time_ns = inner_in_.time_ns;
  in.cameras = inner_in_.cameras;
}

void CanopenPlant::reset(std::uint64_t seed, InputImage& in) {
  // A fresh bus, master and devices per run: a power-up of the line's network. The old
  // master and devices hold references into the old hub: they go first.
  master_.reset();
  devices_.reset();
  bus_now_ns_ = 1'000'000'000;  // away from 0, which the emulation reads as "never"
  hub_ = std::make_unique<LoopbackHub>([this] { return bus_now_ns_; });
  LoopbackBus& master_bus = hub_->add_endpoint();
  LoopbackBus& device_bus = hub_->add_endpoint();
  devices_ = std::make_unique<emulation::LineDevices>(device_bus, config_);
  master_ = std::make_unique<CanopenIo>(master_bus, config_);
  inner_.reset(seed, inner_in_);
  devices_->set_plant_state(inner_in_);
  const BusClock clock{[this] { return bus_now_ns_; },
                       [this](std::int64_t duration_ns) { advance(duration_ns); }};
  startup_ = master_->start_up(clock, true);
  if (!startup_.ok) {
    std::string problems;
    for (const std::string& problem : startup_.problems) problems += "\n  " + problem;
    throw std::runtime_error("CANopen start-up against the emulated line failed:" + problems);
  }
  read_into(in);
}

void CanopenPlant::step(const OutputImage& out, std::int64_t dt_ns, InputImage& in) {
  master_->write(out);  // RPDOs, then the SYNC
  // The devices take the SYNC, apply the commands and answer with the plant's state now.
  const std::int64_t settle_ns = std::min(kSyncSettleNs, dt_ns);
  advance(settle_ns);
  inner_.step(devices_->commands(), dt_ns, inner_in_);
  devices_->set_plant_state(inner_in_);  // sampled at the next SYNC
  advance(dt_ns - settle_ns);
  read_into(in);
}

std::span<const TrueFilletExit> CanopenPlant::drain_exits() { return inner_.drain_exits(); }
std::uint64_t CanopenPlant::fillets_fed() const { return inner_.fillets_fed(); }
std::uint64_t CanopenPlant::fillets_on_line() const { return inner_.fillets_on_line(); }

}  // namespace fl::drivers
