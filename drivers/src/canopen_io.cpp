#include "fl/drivers/canopen_io.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "fl/controller/config_loader.hpp"
#include "hex_text.hpp"
#include "line_signals.hpp"

namespace fl::drivers {

using canopen::NmtState;
using canopen::NodeId;
using canopen::SdoAddress;
using namespace line_signals;  // NOLINT(google-build-using-namespace): the channel table

namespace {

constexpr std::uint8_t kSynchronous = 1;    // PDO transmission type: every SYNC
constexpr std::uint8_t kEventDriven = 255;  // RPDO: applied on receipt

constexpr std::uint16_t kProfileVelocityMode = 3;
constexpr std::uint32_t kDeviceProfileMask = 0xFFFF;  // 0x1000 low word: the CiA profile
constexpr std::uint32_t kDriveProfile = 402;
constexpr std::uint32_t kIoProfile = 401;

}  // namespace

const char* to_string(CanopenEventKind kind) {
  switch (kind) {
    case CanopenEventKind::kHeartbeatLost:
      return "heartbeat lost";
    case CanopenEventKind::kHeartbeatRecovered:
      return "heartbeat recovered";
    case CanopenEventKind::kBootUp:
      return "boot-up";
    case CanopenEventKind::kNmtStateChanged:
      return "NMT state";
    case CanopenEventKind::kEmergency:
      return "EMCY";
    case CanopenEventKind::kEmergencyCleared:
      return "EMCY cleared";
    case CanopenEventKind::kDriveStateChanged:
      return "CiA 402 state";
    case CanopenEventKind::kBusStateChanged:
      return "bus state";
    case CanopenEventKind::kReconfigured:
      return "configured again after its reboot and started";
    case CanopenEventKind::kReconfigurationFailed:
      return "configuration after its reboot failed";
  }
  return "unknown";
}

const char* to_string(ReconfigurationFailure failure) {
  switch (failure) {
    case ReconfigurationFailure::kAborted:
      return "the device aborted the transfer";
    case ReconfigurationFailure::kTimeout:
      return "no answer within the SDO timeout";
    case ReconfigurationFailure::kProtocol:
      return "an answer that does not fit the request";
    case ReconfigurationFailure::kWrongValue:
      return "the device reads another value than the configuration's";
    case ReconfigurationFailure::kSendFailed:
      return "the request could not be sent";
  }
  return "unknown";
}

std::string describe(const CanopenEvent& event) {
  std::string text = "node " + std::to_string(event.node) + ": " + to_string(event.kind);
  switch (event.kind) {
    case CanopenEventKind::kEmergency:
      text += " " + hex_text(event.code, 4) + " " +
              canopen::describe_emcy_code(static_cast<std::uint16_t>(event.code)) + " (register " +
              hex_text(event.detail, 2) + ")";
      break;
    case CanopenEventKind::kNmtStateChanged:
      text += std::string(" ") + canopen::to_string(static_cast<NmtState>(event.code));
      break;
    case CanopenEventKind::kDriveStateChanged:
      text += std::string(" ") + cia402::to_string(static_cast<cia402::State>(event.code));
      break;
    case CanopenEventKind::kBusStateChanged:
      text = std::string("bus: ") + to_string(static_cast<CanErrorState>(event.code));
      break;
    case CanopenEventKind::kReconfigurationFailed:
      text += " at " + hex_text(event.code >> 8U, 4) + ":" + hex_text(event.code & 0xFFU, 2) +
              ": " + to_string(static_cast<ReconfigurationFailure>(event.detail)) +
              " (the node stays out; tried again every second)";
      break;
    default:
      break;
  }
  return text;
}

std::optional<bool> fault_transition(const CanopenEvent& event) {
  const auto drive_faulted = [](std::uint32_t state) {
    return state == static_cast<std::uint32_t>(cia402::State::kFault) ||
           state == static_cast<std::uint32_t>(cia402::State::kFaultReactionActive);
  };
  const auto operational = [](std::uint32_t state) {
    return state == static_cast<std::uint32_t>(NmtState::kOperational);
  };
  const auto bus_off = [](std::uint32_t state) {
    return state == static_cast<std::uint32_t>(CanErrorState::kBusOff);
  };
  // For the state changes, `code` is the new state and `detail` the one before.
  const auto changed = [&event](const auto& is_fault) -> std::optional<bool> {
    const bool now = is_fault(event.code);
    if (now == is_fault(event.detail)) return std::nullopt;
    return now;
  };
  if (event.commanded) return std::nullopt;
  switch (event.kind) {
    case CanopenEventKind::kHeartbeatLost:
    case CanopenEventKind::kEmergency:
    case CanopenEventKind::kBootUp:  // cleared once the node is configured again
    case CanopenEventKind::kReconfigurationFailed:
      return true;
    case CanopenEventKind::kHeartbeatRecovered:
    case CanopenEventKind::kEmergencyCleared:
    case CanopenEventKind::kReconfigured:
      return false;
    case CanopenEventKind::kNmtStateChanged:
      return changed([&](std::uint32_t state) { return !operational(state); });
    case CanopenEventKind::kDriveStateChanged:
      return changed(drive_faulted);
    case CanopenEventKind::kBusStateChanged:
      return changed(bus_off);
  }
  return std::nullopt;
}

CanopenIo::CanopenIo(CanBus& bus, CanConfig config)
    : bus_(bus),
      config_(std::move(config)),
      drive_rpdos_{map_pdo(config_.drive_pdos.rpdo1), map_pdo(config_.drive_pdos.rpdo2)},
      drive_tpdos_{map_pdo(config_.drive_pdos.tpdo1), map_pdo(config_.drive_pdos.tpdo2)},
      io_rpdo_(map_pdo(config_.io_pdos.rpdo1)),
      io_tpdo_(map_pdo(config_.io_pdos.tpdo1)) {
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    nodes_[d].id = config_.drives[d].node_id;
    nodes_[d].timeout_ns = std::int64_t{config_.drives[d].heartbeat_timeout_ms} * 1'000'000;
  }
  for (std::size_t m = 0; m < kIoModuleCount; ++m) {
    nodes_[kDriveCount + m].id = config_.io_modules[m].node_id;
    nodes_[kDriveCount + m].timeout_ns =
        std::int64_t{config_.io_modules[m].heartbeat_timeout_ms} * 1'000'000;
  }
  // Whole scans within the period, so that the heartbeat is never late (the loader refuses a
  // period shorter than a scan).
  const std::int64_t heartbeat_ns = std::int64_t{config_.master.heartbeat_producer_ms} * 1'000'000;
  if (config_.cycle_period_ns > 0) {
    heartbeat_every_ = static_cast<std::uint32_t>(
        std::max<std::int64_t>(1, heartbeat_ns / config_.cycle_period_ns));
  }
  build_routes();
  build_setup_plans();
}

void CanopenIo::build_routes() {
  const auto route = [this](std::uint32_t cob_id, Route kind, std::size_t slot) {
    routes_[cob_id & kCanStandardIdMask] = RouteEntry{kind, static_cast<std::uint8_t>(slot)};
  };
  for (std::size_t slot = 0; slot < kNodeCount; ++slot) {
    route(canopen::kHeartbeatBase + nodes_[slot].id, Route::kHeartbeat, slot);
    route(canopen::kEmcyBase + nodes_[slot].id, Route::kEmergency, slot);
    route(canopen::kSdoResponseBase + nodes_[slot].id, Route::kSdoResponse, slot);
  }
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    route(config_.drives[d].tpdo1_cob_id, Route::kDriveTpdo1, d);
    route(config_.drives[d].tpdo2_cob_id, Route::kDriveTpdo2, d);
  }
  for (std::size_t m = 0; m < kIoModuleCount; ++m) {
    route(config_.io_modules[m].tpdo1_cob_id, Route::kIoTpdo1, m);
  }
}

std::int32_t CanopenIo::velocity_to_drive_units(DriveId drive, float speed_mps) const {
  const DriveNodeConfig& node = config_.drives[index(drive)];
  if (std::isnan(speed_mps)) {
    return 0;  // no target is a standstill, never an undefined conversion (found by fuzzing)
  }
  const double limited =
      std::clamp(static_cast<double>(speed_mps), -static_cast<double>(node.max_speed_mps),
                 static_cast<double>(node.max_speed_mps));
  const double units = std::round(limited * node.velocity_units_per_mps);
  return static_cast<std::int32_t>(std::clamp(units, -2147483648.0, 2147483647.0));
}

std::uint32_t CanopenIo::acceleration_to_drive_units(DriveId drive, float accel_mps2) const {
  const DriveNodeConfig& node = config_.drives[index(drive)];
  // No ramp given (0) means the drive's limit: a zero ramp would never reach the target.
  const double wanted = accel_mps2 > 0.0F ? static_cast<double>(accel_mps2)
                                          : static_cast<double>(node.max_accel_mps2);
  const double limited = std::min(wanted, static_cast<double>(node.max_accel_mps2));
  const double units = std::round(limited * node.acceleration_units_per_mps2);
  return static_cast<std::uint32_t>(std::clamp(units, 1.0, 4294967295.0));
}

// ---------------------------------------------------------------- the cycle

void CanopenIo::read(std::int64_t now_ns, InputImage& in) {
  const std::int64_t previous_read_ns = now_ns_;
  now_ns_ = now_ns;
  for (std::size_t batch = 0; batch < kMaxBatchesPerRead; ++batch) {
    const std::size_t count = bus_.receive(receive_buffer_);
    for (std::size_t i = 0; i < count; ++i) {
      handle_frame(receive_buffer_[i], now_ns);
    }
    if (count < receive_buffer_.size()) {
      break;
    }
  }
  take_send_confirmations();
  // The previous write() came after the previous read(): a SYNC queued since then is its.
  write_applied_ns_.reset();
  if (last_sync_sent_ns_ != 0 && last_sync_queued_ns_ >= previous_read_ns) {
    write_applied_ns_ = last_sync_sent_ns_;
  }
  const CanErrorState bus_state = bus_.error_state();
  if (bus_state != bus_state_) {
    const auto previous = static_cast<std::uint8_t>(bus_state_);
    bus_state_ = bus_state;
    push_event(CanopenEventKind::kBusStateChanged, 0, now_ns, static_cast<std::uint32_t>(bus_state),
               previous);
  }
  check_timeouts(now_ns);
  fill_image(in);
}

void CanopenIo::take_send_confirmations() {
  for (std::size_t batch = 0; batch < kMaxBatchesPerRead; ++batch) {
    const std::size_t count = bus_.take_send_confirmations(confirmation_buffer_);
    for (std::size_t i = 0; i < count; ++i) {
      const CanSendConfirmation& sent = confirmation_buffer_[i];
      CanBusTiming& timing = bus_timing_;
      const std::int64_t delay_ns = sent.sent_ns - sent.queued_ns;
      ++timing.frames_confirmed;
      timing.send_delay_sum_ns += delay_ns;
      timing.send_delay_max_ns = std::max(timing.send_delay_max_ns, delay_ns);
      if (sent.id != canopen::kSyncCobId) {
        continue;
      }
      ++timing.syncs_on_bus;
      if (last_sync_sent_ns_ != 0) {
        const std::int64_t period_ns = sent.sent_ns - last_sync_sent_ns_;
        timing.sync_period_min_ns =
            timing.sync_periods == 0 ? period_ns : std::min(timing.sync_period_min_ns, period_ns);
        timing.sync_period_max_ns = std::max(timing.sync_period_max_ns, period_ns);
        timing.sync_period_sum_ns += period_ns;
        ++timing.sync_periods;
      }
      last_sync_sent_ns_ = sent.sent_ns;
      last_sync_queued_ns_ = sent.queued_ns;
    }
    if (count < confirmation_buffer_.size()) {
      break;
    }
  }
}

double CanBusTiming::sync_period_mean_ns() const {
  return sync_periods == 0
             ? 0.0
             : static_cast<double>(sync_period_sum_ns) / static_cast<double>(sync_periods);
}

std::int64_t CanBusTiming::sync_jitter_ns(std::int64_t cycle_period_ns) const {
  if (sync_periods == 0) {
    return 0;
  }
  return std::max(std::abs(sync_period_min_ns - cycle_period_ns),
                  std::abs(sync_period_max_ns - cycle_period_ns));
}

double CanBusTiming::send_delay_mean_ns() const {
  return frames_confirmed == 0
             ? 0.0
             : static_cast<double>(send_delay_sum_ns) / static_cast<double>(frames_confirmed);
}

void CanopenIo::handle_frame(const CanFrame& frame, std::int64_t now_ns) {
  ++counters_.frames_handled;
  if (frame.extended || frame.remote || frame.error || frame.dlc > kCanMaxDataBytes) {
    ++counters_.malformed_frames;  // CANopen uses 11-bit data frames only
    return;
  }
  const RouteEntry entry = routes_[frame.id & kCanStandardIdMask];
  switch (entry.route) {
    case Route::kNone:
      ++counters_.unknown_cob_id;
      return;
    case Route::kHeartbeat: {
      const auto state = canopen::decode_heartbeat(frame);
      if (!state) {
        ++counters_.malformed_frames;
        return;
      }
      NodeRuntime& node = nodes_[entry.slot];
      node.last_heartbeat_ns = now_ns;
      node.heard = true;
      if (node.lost) {
        node.lost = false;
        push_event(CanopenEventKind::kHeartbeatRecovered, node.id, now_ns, 0);
      }
      if (*state == NmtState::kBootUp) {
        // Cleared once the node is configured again: by start_up(), or by the cycle when it
        // rebooted while running (a transfer to it in flight is void: the device forgot it).
        node.rebooted = true;
        if (!nmt_commanded_) {
          node.reconfigure_wanted = true;
          node.reconfigure_not_before_ns = 0;
          node.last_failure.reset();  // a new boot: its failures are news again
          if (reconfiguration_.active && reconfiguration_.slot == entry.slot) {
            reconfiguration_ = Reconfiguration{};
          }
        }
        push_event(CanopenEventKind::kBootUp, node.id, now_ns, 0);
        node.nmt = NmtState::kPreOperational;  // a booted node enters pre-operational
        return;
      }
      if (*state != node.nmt) {
        const auto previous = static_cast<std::uint8_t>(node.nmt);
        node.nmt = *state;
        push_event(CanopenEventKind::kNmtStateChanged, node.id, now_ns,
                   static_cast<std::uint32_t>(*state), previous);
      }
      // A configured node that fell to pre-operational by itself is started again; one that
      // rebooted lost its configuration and waits for the next start-up.
      node.start_wanted = *state == NmtState::kPreOperational && !nmt_commanded_ && !node.rebooted;
      return;
    }
    case Route::kEmergency: {
      const auto emergency = canopen::decode_emcy(frame);
      if (!emergency) {
        ++counters_.malformed_frames;
        return;
      }
      NodeRuntime& node = nodes_[entry.slot];
      node.emcy_code = emergency->error_code;
      push_event(emergency->error_code == 0 ? CanopenEventKind::kEmergencyCleared
                                            : CanopenEventKind::kEmergency,
                 node.id, now_ns, emergency->error_code, emergency->error_register);
      return;
    }
    case Route::kSdoResponse:
      if (reconfiguration_.active && reconfiguration_.awaiting &&
          reconfiguration_.slot == entry.slot) {
        take_reconfiguration_response(frame, now_ns);
      } else {
        ++counters_.unexpected_sdo;  // no transfer of the cycle's waits for it
      }
      return;
    case Route::kDriveTpdo1:
    case Route::kDriveTpdo2: {
      const MappedPdo& pdo = drive_tpdos_[entry.route == Route::kDriveTpdo1 ? 0 : 1];
      std::array<std::uint32_t, canopen::kMaxPdoEntries> values{};
      if (!canopen::unpack_pdo(frame, pdo.mapping, std::span(values.data(), pdo.mapping.count))) {
        ++counters_.malformed_frames;
        return;
      }
      for (std::uint8_t i = 0; i < pdo.mapping.count; ++i) {
        apply_drive_signal(entry.slot, pdo.signals[i], values[i], now_ns);
      }
      return;
    }
    case Route::kIoTpdo1: {
      const canopen::PdoMapping& mapping = io_tpdo_.mapping;
      std::array<std::uint32_t, canopen::kMaxPdoEntries> values{};
      if (!canopen::unpack_pdo(frame, mapping, std::span(values.data(), mapping.count))) {
        ++counters_.malformed_frames;
        return;
      }
      IoRuntime& module = io_[entry.slot];
      for (std::uint8_t i = 0; i < mapping.count; ++i) {
        const PdoSignal signal = io_tpdo_.signals[i];
        if (signal == PdoSignal::kDigitalInputs) {
          module.digital_inputs = static_cast<std::uint8_t>(values[i]);
        } else {
          const auto channel =
              static_cast<std::size_t>(signal) - static_cast<std::size_t>(PdoSignal::kAnalogInput1);
          module.analog_inputs[channel] = static_cast<std::int16_t>(sign_extend(values[i], 16));
        }
      }
      module.received = true;
      return;
    }
  }
}

CanopenIo::MappedPdo CanopenIo::map_pdo(const canopen::PdoMapping& mapping) {
  MappedPdo pdo;
  pdo.mapping = mapping;
  for (std::uint8_t i = 0; i < mapping.count; ++i) {
    // The loader admitted only known objects, so every entry has its signal.
    pdo.signals[i] = find_pdo_signal(mapping.entries[i]).value_or(PdoSignal::kCount);
  }
  pdo.cyclic = carries_cyclic_command(mapping);
  return pdo;
}

void CanopenIo::apply_drive_signal(std::size_t slot, PdoSignal signal, std::uint32_t raw,
                                   std::int64_t now_ns) {
  DriveRuntime& drive = drives_[slot];
  switch (signal) {
    case PdoSignal::kStatusword: {
      drive.statusword = static_cast<std::uint16_t>(raw);
      const cia402::State state = cia402::decode_statusword(drive.statusword);
      if (state != drive.state) {
        const auto previous = static_cast<std::uint8_t>(drive.state);
        drive.state = state;
        push_event(CanopenEventKind::kDriveStateChanged, nodes_[slot].id, now_ns,
                   static_cast<std::uint32_t>(state), previous);
      }
      drive.status_received = true;
      return;
    }
    case PdoSignal::kPositionActual: {
      const std::int32_t position = sign_extend(raw, 32);
      if (drive.position_received) {
        // Unwrap the 32-bit counter: the difference modulo 2^32 is the travel since the
        // last TPDO (far less than 2^31 counts in one cycle).
        const std::uint32_t delta_raw = static_cast<std::uint32_t>(position) -
                                        static_cast<std::uint32_t>(drive.last_position_raw);
        drive.encoder_counts += sign_extend(delta_raw, 32);
      } else {
        drive.encoder_counts = position;
        drive.position_received = true;
      }
      drive.last_position_raw = position;
      return;
    }
    case PdoSignal::kVelocityActual:
      drive.velocity_raw = sign_extend(raw, 32);
      return;
    default:
      return;  // not a drive's TPDO object: the loader refuses such mappings
  }
}

void CanopenIo::check_timeouts(std::int64_t now_ns) {
  for (NodeRuntime& node : nodes_) {
    if (node.heard && !node.lost && now_ns - node.last_heartbeat_ns > node.timeout_ns) {
      node.lost = true;
      ++counters_.heartbeats_lost;
      push_event(CanopenEventKind::kHeartbeatLost, node.id, now_ns, 0);
    }
  }
}

bool CanopenIo::node_healthy(std::size_t slot) const {
  const NodeRuntime& node = nodes_[slot];
  return node.heard && !node.lost && !node.rebooted && node.nmt == NmtState::kOperational &&
         bus_state_ != CanErrorState::kBusOff;
}

void CanopenIo::fill_image(InputImage& in) const {
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    const DriveRuntime& drive = drives_[d];
    const bool healthy = node_healthy(d) && drive.status_received;
    const bool drive_fault =
        drive.state == cia402::State::kFault || drive.state == cia402::State::kFaultReactionActive;
    DriveFeedback& feedback = in.drives[d];
    feedback.fault = !healthy || drive_fault || nodes_[d].emcy_code != 0;
    feedback.ready = !feedback.fault && drive.state == cia402::State::kOperationEnabled;
    feedback.speed_mps = healthy ? static_cast<float>(static_cast<double>(drive.velocity_raw) /
                                                      config_.drives[d].velocity_units_per_mps)
                                 : 0.0F;
    feedback.encoder_counts = drive.encoder_counts;  // held while lost: no travel invented
  }

  // A module with an active emergency (EMCY error code not yet reset to 0) may report inputs
  // it cannot vouch for: it is read like a lost one, safe values and the chain open.
  const auto module_ok = [this](IoModuleId id) {
    const std::size_t slot = kDriveCount + index(id);
    return node_healthy(slot) && io_[index(id)].received && nodes_[slot].emcy_code == 0;
  };
  const IoScaling& scaling = config_.io_scaling;
  const bool infeed_ok = module_ok(IoModuleId::kInfeed);
  const bool stations_ok = module_ok(IoModuleId::kStations);
  const bool safety_ok = module_ok(IoModuleId::kSafety);
  const IoRuntime& infeed = io_[index(IoModuleId::kInfeed)];
  const IoRuntime& stations = io_[index(IoModuleId::kStations)];
  const IoRuntime& safety = io_[index(IoModuleId::kSafety)];

  if (infeed_ok) {
    in.takt_beam_broken = (infeed.digital_inputs & infeed_io::kBeamBrokenBit) != 0;
    in.leveller_overload = (infeed.digital_inputs & infeed_io::kLevellerOverloadBit) != 0;
    in.level_mm = static_cast<float>(infeed.analog_inputs[infeed_io::kLevelChannel]) *
                  scaling.level_mm_per_count;
    in.hopper_opening_mm =
        static_cast<float>(infeed.analog_inputs[infeed_io::kHopperOpeningChannel]) *
        scaling.hopper_opening_mm_per_count;
    in.leveller_speed_rpm =
        static_cast<float>(infeed.analog_inputs[infeed_io::kLevellerSpeedChannel]) *
        scaling.leveller_rpm_per_count;
  } else {
    in.takt_beam_broken = false;
    in.leveller_overload = true;  // the leveller's own fault path stops the infeed
    in.level_mm = 0.0F;
    in.hopper_opening_mm = 0.0F;
    in.leveller_speed_rpm = 0.0F;
  }
  if (stations_ok) {
    in.flip_plate1_flipping = (stations.digital_inputs & stations_io::kPlate1FlippingBit) != 0;
    in.flip_plate2_flipping = (stations.digital_inputs & stations_io::kPlate2FlippingBit) != 0;
    in.squeeze_roller_down = (stations.digital_inputs & stations_io::kSqueezeDownBit) != 0;
    in.centring_position_mm =
        static_cast<float>(stations.analog_inputs[stations_io::kCentringPositionChannel]) *
        scaling.centring_mm_per_count;
  }  // else: the last values stay; estop_ok below stops the line
  const bool all_io_ok = infeed_ok && stations_ok && safety_ok;
  in.estop_ok = all_io_ok && (safety.digital_inputs & safety_io::kEstopChainClosedBit) != 0;
  in.start_request = safety_ok && (safety.digital_inputs & safety_io::kStartBit) != 0;
  in.stop_request = !safety_ok || (safety.digital_inputs & safety_io::kStopBit) != 0;
  in.fault_reset_request = safety_ok && (safety.digital_inputs & safety_io::kFaultResetBit) != 0;
}

void CanopenIo::send_drive_rpdo(std::size_t drive_index, std::size_t rpdo, std::uint32_t cob_id,
                                const DriveRpdoValues& command) {
  const MappedPdo& pdo = drive_rpdos_[rpdo];
  const canopen::PdoMapping& mapping = pdo.mapping;
  if (mapping.count == 0) return;
  std::array<std::uint32_t, canopen::kMaxPdoEntries> values{};
  fill_drive_rpdo(pdo, command, values);
  DriveRuntime& drive = drives_[drive_index];
  if (!pdo.cyclic && drive.rpdo_sent[rpdo] && values == drive.rpdo_last[rpdo]) {
    return;  // the ramps have not changed
  }
  if (bus_.send(canopen::pack_pdo(cob_id, mapping,
                                  std::span<const std::uint32_t>(values.data(), mapping.count)))) {
    drive.rpdo_last[rpdo] = values;
    drive.rpdo_sent[rpdo] = true;
  } else {
    ++counters_.send_failures;  // a ramp-only PDO is retried next cycle: rpdo_sent stays behind
  }
}

void CanopenIo::fill_drive_rpdo(const MappedPdo& pdo, const DriveRpdoValues& command,
                                std::array<std::uint32_t, canopen::kMaxPdoEntries>& values) {
  for (std::uint8_t i = 0; i < pdo.mapping.count; ++i) {
    switch (pdo.signals[i]) {
      case PdoSignal::kControlword:
        values[i] = command.controlword;
        break;
      case PdoSignal::kTargetVelocity:
        values[i] = command.target_velocity;
        break;
      case PdoSignal::kProfileAcceleration:
      case PdoSignal::kProfileDeceleration:  // the line ramps down as it ramps up
        values[i] = command.acceleration;
        break;
      default:
        values[i] = 0;  // not a drive's RPDO object: the loader refuses such mappings
    }
  }
}

void CanopenIo::write(const OutputImage& out) {
  fault_reset_pressed_ =
      (io_[index(IoModuleId::kSafety)].digital_inputs & safety_io::kFaultResetBit) != 0 &&
      node_healthy(kDriveCount + index(IoModuleId::kSafety));
  reset_phase_ = !reset_phase_;
  const auto send = [this](const CanFrame& frame) {
    if (!bus_.send(frame)) {
      ++counters_.send_failures;
    }
  };
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    const DriveCommand& command = out.drives[d];
    const DriveNodeConfig& node = config_.drives[d];
    DriveRuntime& drive = drives_[d];
    const cia402::Goal goal = command.enable                   ? cia402::Goal::kOperationEnabled
                              : out.state == LineState::kFault ? cia402::Goal::kQuickStop
                                                               : cia402::Goal::kSwitchedOn;
    const std::uint16_t controlword =
        cia402::master_controlword(drive.state, goal, fault_reset_pressed_, reset_phase_);
    const std::int32_t target =
        command.enable && drive.state == cia402::State::kOperationEnabled
            ? velocity_to_drive_units(static_cast<DriveId>(d), command.speed_mps)
            : 0;
    const std::uint32_t accel =
        acceleration_to_drive_units(static_cast<DriveId>(d), command.accel_mps2);
    const DriveRpdoValues values{controlword, to_wire(target), accel};
    send_drive_rpdo(d, 0, node.rpdo1_cob_id, values);
    send_drive_rpdo(d, 1, node.rpdo2_cob_id, values);
  }

  const IoScaling& scaling = config_.io_scaling;
  // A module's outputs: the digital output byte and analogue outputs 1 to 3, placed where
  // the configured mapping puts them.
  const auto analog = [](float value, float units_per_count) {
    return to_wire(to_analog_counts(value, units_per_count)) & 0xFFFFU;
  };
  const auto send_outputs = [&](IoModuleId module, const IoOutputs& outputs) {
    const canopen::PdoMapping& mapping = io_rpdo_.mapping;
    std::array<std::uint32_t, canopen::kMaxPdoEntries> values{};
    for (std::uint8_t i = 0; i < mapping.count; ++i) {
      const PdoSignal signal = io_rpdo_.signals[i];
      values[i] = signal == PdoSignal::kDigitalOutputs
                      ? outputs.digital
                      : outputs.analog[static_cast<std::size_t>(signal) -
                                       static_cast<std::size_t>(PdoSignal::kAnalogOutput1)];
    }
    send(canopen::pack_pdo(config_.io_modules[index(module)].rpdo1_cob_id, mapping,
                           std::span<const std::uint32_t>(values.data(), mapping.count)));
  };
  {
    IoOutputs outputs;
    outputs.analog[infeed_io::kHopperOpeningOut] =
        analog(out.hopper_opening_mm, scaling.hopper_opening_mm_per_count);
    outputs.analog[infeed_io::kLevellerSpeedOut] =
        analog(out.leveller_speed_rpm, scaling.leveller_rpm_per_count);
    send_outputs(IoModuleId::kInfeed, outputs);
  }
  {
    std::uint8_t outputs = 0;
    outputs |= out.flip_plate1_flip ? stations_io::kPlate1FlipOut : 0;
    outputs |= out.flip_plate2_flip ? stations_io::kPlate2FlipOut : 0;
    outputs |= out.centring_stroke ? stations_io::kCentringStrokeOut : 0;
    outputs |= out.squeeze_roller_down ? stations_io::kSqueezeDownOut : 0;
    outputs |= out.final_reject ? stations_io::kFinalRejectOut : 0;
    IoOutputs stations;
    stations.digital = outputs;
    stations.analog[stations_io::kCentringShiftOut] =
        analog(out.centring_shift_mm, scaling.centring_mm_per_count);
    send_outputs(IoModuleId::kStations, stations);
  }
  {
    std::uint8_t lamps = 0;
    lamps |= out.state == LineState::kRunning ? safety_io::kRunningLampOut : 0;
    lamps |= out.state == LineState::kFault ? safety_io::kFaultLampOut : 0;
    IoOutputs safety;
    safety.digital = lamps;
    send_outputs(IoModuleId::kSafety, safety);
  }
  advance_reconfiguration(now_ns_);
  for (NodeRuntime& node : nodes_) {
    if (!node.start_wanted) continue;
    node.start_wanted = false;
    if (bus_.send(canopen::make_nmt(canopen::NmtCommand::kStart, node.id))) {
      ++counters_.nodes_restarted;
    } else {
      ++counters_.send_failures;
    }
  }
  // The master's heartbeat, which every device watches (0x1016:01): never later than its
  // period, as the scans fall.
  if (++scans_since_heartbeat_ >= heartbeat_every_) {
    scans_since_heartbeat_ = 0;
    if (bus_.send(canopen::make_heartbeat(config_.master.node_id, NmtState::kOperational))) {
      ++counters_.heartbeats_sent;
    } else {
      ++counters_.send_failures;
    }
  }
  // SYNC last: synchronous RPDOs take effect at it, and the TPDOs it triggers carry the
  // state the next read() sees.
  if (bus_.send(canopen::make_sync())) {
    ++counters_.syncs_sent;
  } else {
    ++counters_.send_failures;
  }
}

// ---------------------------------------------------------------- events and status

void CanopenIo::push_event(CanopenEventKind kind, NodeId node, std::int64_t time_ns,
                           std::uint32_t code, std::uint8_t detail) {
  const std::size_t tail = event_tail_.load(std::memory_order_relaxed);
  const std::size_t head = event_head_.load(std::memory_order_acquire);
  if (tail - head >= kEventCapacity) {
    ++counters_.events_dropped;
    return;
  }
  // While the master itself resets, starts or stops the nodes, their boot-ups and NMT
  // changes are what it asked for.
  const bool commanded = nmt_commanded_ && (kind == CanopenEventKind::kBootUp ||
                                            kind == CanopenEventKind::kNmtStateChanged);
  events_[tail % kEventCapacity] = CanopenEvent{kind, node, time_ns, code, detail, commanded};
  event_tail_.store(tail + 1, std::memory_order_release);
}

bool CanopenIo::pop_event(CanopenEvent& event) {
  const std::size_t head = event_head_.load(std::memory_order_relaxed);
  const std::size_t tail = event_tail_.load(std::memory_order_acquire);
  if (head == tail) {
    return false;
  }
  event = events_[head % kEventCapacity];
  event_head_.store(head + 1, std::memory_order_release);
  return true;
}

std::size_t CanopenIo::log_events(const std::function<void(const CanopenEvent&)>& observer) {
  std::size_t count = 0;
  CanopenEvent event;
  while (pop_event(event)) {
    ++count;
    if (observer) observer(event);
    const bool bad = event.kind == CanopenEventKind::kHeartbeatLost ||
                     event.kind == CanopenEventKind::kEmergency ||
                     event.kind == CanopenEventKind::kReconfigurationFailed ||
                     (event.kind == CanopenEventKind::kBusStateChanged && event.code != 0);
    if (bad) {
      spdlog::warn("canopen: {}", describe(event));
    } else {
      spdlog::info("canopen: {}", describe(event));
    }
  }
  return count;
}

NodeStatus CanopenIo::status_of(std::size_t slot) const {
  const NodeRuntime& node = nodes_[slot];
  NodeStatus status;
  status.node = node.id;
  status.heard = node.heard;
  status.lost = node.lost;
  status.nmt = node.nmt;
  status.rebooted = node.rebooted;
  status.emcy_code = node.emcy_code;
  if (slot < kDriveCount) {
    status.drive_state = drives_[slot].state;
  }
  return status;
}

NodeStatus CanopenIo::drive_status(DriveId drive) const { return status_of(index(drive)); }
NodeStatus CanopenIo::io_status(IoModuleId module) const {
  return status_of(kDriveCount + index(module));
}

// ---------------------------------------------------------------- start-up

void CanopenIo::append_pdo_steps(std::vector<SetupStep>& steps, std::uint16_t communication_index,
                                 std::uint16_t mapping_index, std::uint32_t cob_id,
                                 std::uint8_t transmission_type,
                                 const canopen::PdoMapping& mapping) const {
  using Kind = SetupStep::Kind;
  // CiA 301 7.5.2.35/36: a PDO's mapping may only change while the PDO is invalid (bit 31)
  // and its mapping count is 0.
  steps.push_back({Kind::kWrite, {communication_index, 1}, cob_id | canopen::kPdoCobIdInvalid, 4});
  if (config_.write_pdo_mappings) {
    steps.push_back({Kind::kWrite, {mapping_index, 0}, 0, 1});
    for (std::uint8_t i = 0; i < mapping.count; ++i) {
      steps.push_back({Kind::kWrite,
                       {mapping_index, static_cast<std::uint8_t>(i + 1)},
                       mapping.entries[i].mapping_value(),
                       4});
    }
    steps.push_back({Kind::kWrite, {mapping_index, 0}, mapping.count, 1});
  } else {
    // A built-in mapping is read back: the master packs by can.yaml's, so they must agree.
    const char* differs = "the built-in PDO mapping differs from can.yaml's";
    steps.push_back(
        {Kind::kExpect, {mapping_index, 0}, mapping.count, 0, 0xFFFFFFFFU, differs, &mapping});
    for (std::uint8_t i = 0; i < mapping.count; ++i) {
      steps.push_back({Kind::kExpect,
                       {mapping_index, static_cast<std::uint8_t>(i + 1)},
                       mapping.entries[i].mapping_value(),
                       0,
                       0xFFFFFFFFU,
                       differs,
                       &mapping});
    }
  }
  steps.push_back({Kind::kWrite, {communication_index, 2}, transmission_type, 1});
  steps.push_back({Kind::kWrite, {communication_index, 1}, cob_id, 4});
}

std::uint32_t CanopenIo::master_heartbeat_consumer() const {
  // 0x1016:01: the producer's node id in bits 16..23, the consumer time in ms in bits 0..15.
  return (std::uint32_t{config_.master.node_id} << 16U) | config_.master.heartbeat_timeout_ms;
}

void CanopenIo::build_setup_plans() {
  using Kind = SetupStep::Kind;
  const auto write = [](std::vector<SetupStep>& steps, SdoAddress address, std::uint32_t value,
                        std::uint8_t size) {
    steps.push_back({Kind::kWrite, address, value, size});
  };
  const auto expect = [](std::vector<SetupStep>& steps, SdoAddress address, std::uint32_t value,
                         std::uint32_t mask, const char* mismatch) {
    steps.push_back({Kind::kExpect, address, value, 0, mask, mismatch});
  };
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    const DriveNodeConfig& node = config_.drives[d];
    const DrivePdoMappings& pdos = config_.drive_pdos;
    std::vector<SetupStep>& steps = setup_plans_[d];
    // A cyclic RPDO takes effect at the SYNC, with every other; a ramp-only one on receipt.
    const auto transmission = [](const MappedPdo& pdo) {
      return pdo.cyclic ? kSynchronous : kEventDriven;
    };
    const std::uint32_t max_accel =
        acceleration_to_drive_units(static_cast<DriveId>(d), node.max_accel_mps2);
    // Watch the master's heartbeat and quick-stop (0x6007 = 3) at the rated deceleration when
    // it falls silent: a dead controller must not leave a belt running.
    constexpr std::uint32_t kQuickStopOnLoss = 3;
    expect(steps, {0x1000, 0}, kDriveProfile, kDeviceProfileMask,
           "device type (0x1000) is not a CiA 402 drive");
    write(steps, {0x1017, 0}, node.heartbeat_producer_ms, 2);
    write(steps, {0x1016, 1}, master_heartbeat_consumer(), 4);
    write(steps, {0x6007, 0}, kQuickStopOnLoss, 2);
    write(steps, {0x6085, 0}, max_accel, 4);
    append_pdo_steps(steps, 0x1400, 0x1600, node.rpdo1_cob_id, transmission(drive_rpdos_[0]),
                     pdos.rpdo1);
    append_pdo_steps(steps, 0x1401, 0x1601, node.rpdo2_cob_id, transmission(drive_rpdos_[1]),
                     pdos.rpdo2);
    append_pdo_steps(steps, 0x1800, 0x1A00, node.tpdo1_cob_id, kSynchronous, pdos.tpdo1);
    append_pdo_steps(steps, 0x1801, 0x1A01, node.tpdo2_cob_id, node.tpdo2_every_syncs, pdos.tpdo2);
    write(steps, {0x6060, 0}, kProfileVelocityMode, 1);
    write(steps, {0x6083, 0}, max_accel, 4);
    write(steps, {0x6084, 0}, max_accel, 4);
    expect(steps, {0x6061, 0}, kProfileVelocityMode, 0xFFU,
           "mode of operation display (0x6061) is not profile velocity (3)");
  }
  for (std::size_t m = 0; m < kIoModuleCount; ++m) {
    const IoModuleConfig& node = config_.io_modules[m];
    std::vector<SetupStep>& steps = setup_plans_[kDriveCount + m];
    expect(steps, {0x1000, 0}, kIoProfile, kDeviceProfileMask,
           "device type (0x1000) is not a CiA 401 I/O module");
    // Watch the master's heartbeat; when it falls silent every digital output goes off (flip
    // plates back, roller up, lamps off) and every analogue output to 0 (hopper gate closed,
    // leveller and centring shift at rest).
    write(steps, {0x1017, 0}, node.heartbeat_producer_ms, 2);
    write(steps, {0x1016, 1}, master_heartbeat_consumer(), 4);
    write(steps, {0x6206, 1}, 0xFF, 1);
    write(steps, {0x6207, 1}, 0x00, 1);
    for (std::uint8_t channel = 1; channel <= 3; ++channel) {
      write(steps, {0x6443, channel}, 1, 1);
      write(steps, {0x6444, channel}, 0, 4);
    }
    append_pdo_steps(steps, 0x1400, 0x1600, node.rpdo1_cob_id, kSynchronous, config_.io_pdos.rpdo1);
    append_pdo_steps(steps, 0x1800, 0x1A00, node.tpdo1_cob_id, kSynchronous, config_.io_pdos.tpdo1);
  }
}

std::string CanopenIo::describe_mapping_mismatch(SdoClient& sdo, std::size_t slot,
                                                 const SetupStep& step) {
  const auto describe = [](const canopen::PdoMapping& entries) {
    std::string text;
    for (std::uint8_t i = 0; i < entries.count; ++i) {
      text += (i == 0 ? "" : ", ") + hex_text(entries.entries[i].mapping_value(), 8);
    }
    return text.empty() ? std::string("nothing") : text;
  };
  const std::uint16_t mapping_index = step.address.index;
  const std::string where =
      "node " + std::to_string(nodes_[slot].id) + ": mapping " + hex_text(mapping_index, 4);
  const SdoResult count = sdo.upload(nodes_[slot].id, {mapping_index, 0});
  if (!count.ok() || count.value > canopen::kMaxPdoEntries) {
    return where + ": the device reports " +
           (count.ok() ? std::to_string(count.value) + " entries, a PDO holds at most 8"
                       : "no entry count: " + count.describe());
  }
  canopen::PdoMapping device;
  device.count = static_cast<std::uint8_t>(count.value);
  for (std::uint8_t i = 0; i < device.count; ++i) {
    const SdoResult entry =
        sdo.upload(nodes_[slot].id, {mapping_index, static_cast<std::uint8_t>(i + 1)});
    if (!entry.ok()) {
      return where + ": SDO read of entry " + std::to_string(i + 1) +
             " failed: " + entry.describe();
    }
    device.entries[i] = canopen::PdoEntry::from_mapping_value(entry.value);
  }
  return where + " on the device is " + describe(device) + ", can.yaml maps " +
         describe(*step.mapping) + " (pdo_mapping.write_to_devices is false: the device's is kept)";
}

bool CanopenIo::configure_node(SdoClient& sdo, std::size_t slot,
                               std::vector<std::string>& problems) {
  const NodeId id = nodes_[slot].id;
  for (const SetupStep& step : setup_plans_[slot]) {
    const bool writing = step.kind == SetupStep::Kind::kWrite;
    const SdoResult result = writing ? sdo.download(id, step.address, step.value, step.size_bytes)
                                     : sdo.upload(id, step.address);
    const std::string object =
        hex_text(step.address.index, 4) + ":" + hex_text(step.address.subindex, 2);
    if (!result.ok()) {
      problems.push_back(
          node_label(slot) + ": SDO " +
          (writing ? "write " + object + " = " + hex_text(step.value, 8) : "read " + object) +
          " failed: " + result.describe());
      return false;
    }
    if (!writing && !step.accepts(result.value)) {
      problems.push_back(step.mapping != nullptr ? describe_mapping_mismatch(sdo, slot, step)
                                                 : node_label(slot) + ": " + step.mismatch +
                                                       ": reads " + hex_text(result.value, 8));
      return false;
    }
  }
  node_configured(slot);
  return true;
}

void CanopenIo::node_configured(std::size_t slot) {
  if (slot >= kDriveCount) return;
  const std::uint32_t max_accel =
      acceleration_to_drive_units(static_cast<DriveId>(slot), config_.drives[slot].max_accel_mps2);
  const DriveRpdoValues configured{0, 0, max_accel};
  for (std::size_t rpdo = 0; rpdo < 2; ++rpdo) {
    if (!drive_rpdos_[rpdo].cyclic) {
      fill_drive_rpdo(drive_rpdos_[rpdo], configured, drives_[slot].rpdo_last[rpdo]);
      drives_[slot].rpdo_sent[rpdo] = true;
    }
  }
}

// ---------------------------------------------------------------- a rebooted node, in the cycle

void CanopenIo::advance_reconfiguration(std::int64_t now_ns) {
  if (!reconfiguration_.active) {
    // The lowest slot first: drives before modules, as at start-up.
    for (std::size_t slot = 0; slot < kNodeCount; ++slot) {
      if (!nodes_[slot].reconfigure_wanted) continue;
      if (now_ns < nodes_[slot].reconfigure_not_before_ns) continue;
      nodes_[slot].reconfigure_wanted = false;
      reconfiguration_ = Reconfiguration{true, slot, 0, false, 0};
      break;
    }
    if (!reconfiguration_.active) return;
  }
  Reconfiguration& run = reconfiguration_;
  const std::vector<SetupStep>& steps = setup_plans_[run.slot];
  const NodeId id = nodes_[run.slot].id;
  if (run.awaiting) {
    if (now_ns - run.sent_ns <= std::int64_t{config_.sdo_timeout_ms} * 1'000'000) return;
    // Tell the device the transfer is over, as the blocking client does.
    bus_.send(canopen::make_sdo_abort(canopen::kSdoRequestBase + id, steps[run.step].address,
                                      canopen::sdo_abort::kTimeout));
    end_reconfiguration(now_ns, ReconfigurationFailure::kTimeout);
    return;
  }
  if (run.step == steps.size()) {
    end_reconfiguration(now_ns, std::nullopt);
    return;
  }
  const SetupStep& step = steps[run.step];
  const CanFrame request =
      step.kind == SetupStep::Kind::kWrite
          ? canopen::make_sdo_download(id, step.address, step.value, step.size_bytes)
          : canopen::make_sdo_upload(id, step.address);
  if (!bus_.send(request)) {
    ++counters_.send_failures;
    end_reconfiguration(now_ns, ReconfigurationFailure::kSendFailed);
    return;
  }
  run.awaiting = true;
  run.sent_ns = now_ns;
}

void CanopenIo::take_reconfiguration_response(const CanFrame& frame, std::int64_t now_ns) {
  Reconfiguration& run = reconfiguration_;
  const std::vector<SetupStep>& steps = setup_plans_[run.slot];
  const SetupStep& step = steps[run.step];
  const canopen::SdoResponse response = canopen::decode_sdo_response(frame);
  run.awaiting = false;
  if (response.kind == canopen::SdoResponseKind::kAbort) {
    end_reconfiguration(now_ns, ReconfigurationFailure::kAborted);
    return;
  }
  const bool writing = step.kind == SetupStep::Kind::kWrite;
  const bool fits = response.address == step.address &&
                    response.kind == (writing ? canopen::SdoResponseKind::kDownloadDone
                                              : canopen::SdoResponseKind::kUploadExpedited);
  if (!fits) {
    bus_.send(canopen::make_sdo_abort(canopen::kSdoRequestBase + nodes_[run.slot].id, step.address,
                                      canopen::sdo_abort::kGeneral));
    end_reconfiguration(now_ns, ReconfigurationFailure::kProtocol);
    return;
  }
  if (!writing && !step.accepts(response.value)) {
    end_reconfiguration(now_ns, ReconfigurationFailure::kWrongValue);
    return;
  }
  ++run.step;
}

void CanopenIo::end_reconfiguration(std::int64_t now_ns,
                                    std::optional<ReconfigurationFailure> failure) {
  Reconfiguration& run = reconfiguration_;
  NodeRuntime& node = nodes_[run.slot];
  if (failure) {
    const SdoAddress address = setup_plans_[run.slot][run.step].address;
    const std::uint32_t code = (std::uint32_t{address.index} << 8U) | address.subindex;
    const auto reason = static_cast<std::uint8_t>(*failure);
    ++counters_.reconfigurations_failed;
    const NodeRuntime::FailedTry failed{code, reason};
    if (node.last_failure != failed) {
      push_event(CanopenEventKind::kReconfigurationFailed, node.id, now_ns, code, reason);
    }
    node.last_failure = failed;
    node.reconfigure_wanted = true;
    node.reconfigure_not_before_ns = now_ns + kReconfigureRetryNs;
  } else {
    node.last_failure.reset();
    node_configured(run.slot);
    node.rebooted = false;
    node.start_wanted = true;  // this write() sends it NMT start
    ++counters_.nodes_reconfigured;
    push_event(CanopenEventKind::kReconfigured, node.id, now_ns, 0);
  }
  run = Reconfiguration{};
}

bool CanopenIo::cycle_until(const BusClock& clock, const OutputImage& out, InputImage& in,
                            const std::function<bool()>& done) {
  const std::int64_t deadline_ns =
      clock.now_ns() + std::int64_t{config_.enable_timeout_ms} * 1'000'000;
  while (clock.now_ns() < deadline_ns) {
    write(out);
    clock.wait_ns(config_.cycle_period_ns);
    read(clock.now_ns(), in);
    if (done()) return true;
  }
  return false;
}

std::string CanopenIo::node_label(std::size_t slot) const {
  const std::string device =
      slot < kDriveCount
          ? "drive " + std::string(config_name(static_cast<DriveId>(slot)))
          : "I/O module " + std::string(config_name(static_cast<IoModuleId>(slot - kDriveCount)));
  return "node " + std::to_string(nodes_[slot].id) + " (" + device + ")";
}

StartupReport CanopenIo::start_up(const BusClock& clock, bool enable_drives) {
  nmt_commanded_ = true;
  StartupReport report = run_start_up(clock, enable_drives);
  nmt_commanded_ = false;
  return report;
}

StartupReport CanopenIo::run_start_up(const BusClock& clock, bool enable_drives) {
  StartupReport report;
  const std::int64_t started_ns = clock.now_ns();
  reconfiguration_ = Reconfiguration{};  // the start-up configures every node afresh
  for (NodeRuntime& node : nodes_) {
    node.heard = false;
    node.lost = false;
    node.rebooted = false;
    node.reconfigure_wanted = false;
    node.emcy_code = 0;
    node.nmt = NmtState::kBootUp;
  }
  drives_ = {};
  io_ = {};

  // 1. NMT reset node: every device restarts from its defaults and sends boot-up.
  if (!bus_.send(canopen::make_nmt(canopen::NmtCommand::kResetNode, canopen::kAllNodes))) {
    report.problems.push_back("NMT reset node could not be sent");
    return report;
  }
  const std::int64_t boot_deadline_ns =
      clock.now_ns() + std::int64_t{config_.boot_timeout_ms} * 1'000'000;
  while (true) {
    const std::size_t count = bus_.receive(receive_buffer_);
    for (std::size_t i = 0; i < count; ++i) {
      handle_frame(receive_buffer_[i], clock.now_ns());
    }
    const bool all_booted =
        std::all_of(nodes_.begin(), nodes_.end(), [](const NodeRuntime& n) { return n.rebooted; });
    if (all_booted) {
      break;
    }
    if (clock.now_ns() >= boot_deadline_ns) {
      for (std::size_t slot = 0; slot < kNodeCount; ++slot) {
        if (!nodes_[slot].rebooted) {
          report.problems.push_back(node_label(slot) + ": no boot-up message within " +
                                    std::to_string(config_.boot_timeout_ms) + " ms");
        }
      }
      break;
    }
    if (count == 0) {
      clock.wait_ns(SdoClient::kPollStepNs);
    }
  }

  // 2. SDO configuration of every node that booted.
  SdoClient sdo(bus_, clock, std::int64_t{config_.sdo_timeout_ms} * 1'000'000,
                [this, &clock](const CanFrame& frame) { handle_frame(frame, clock.now_ns()); });
  bool configured = report.problems.empty();
  for (std::size_t slot = 0; slot < kNodeCount; ++slot) {
    if (nodes_[slot].rebooted) {
      configured = configure_node(sdo, slot, report.problems) && configured;
    }
  }

  // 3. NMT start: PDOs flow from the next SYNC on.
  if (!bus_.send(canopen::make_nmt(canopen::NmtCommand::kStart, canopen::kAllNodes))) {
    report.problems.push_back("NMT start could not be sent");
    configured = false;
  }
  const std::int64_t now = clock.now_ns();
  for (NodeRuntime& node : nodes_) {
    node.rebooted = false;
    node.last_heartbeat_ns = now;  // the consumer timeouts start now
    // The heartbeat will confirm; until then the master takes its own command as the state.
    // A heartbeat sent before the node took the NMT start still says pre-operational, so
    // step 4 waits for one heard after it.
    node.nmt = NmtState::kOperational;
    node.heard = false;
  }

  // 4. Cycles with the idle image until every node's TPDOs have arrived once and its heartbeat
  //    has reported Operational, so that the first scan reads the devices (the safety chain,
  //    the statuswords) and not an empty image or a stale pre-operational state, either of
  //    which would latch a fault. With enable_drives the same cycles take every drive through
  //    CiA 402 to Operation Enabled, one transition per cycle as the statuswords confirm.
  if (configured) {
    OutputImage out{};
    if (enable_drives) {
      out.state = LineState::kStarting;
      for (DriveCommand& command : out.drives) {
        command.enable = true;
      }
    }
    InputImage in{};
    const auto node_answered = [this](std::size_t slot) {
      return slot < kDriveCount ? drives_[slot].status_received && drives_[slot].position_received
                                : io_[slot - kDriveCount].received;
    };
    const auto node_operational = [this](std::size_t slot) {
      return nodes_[slot].heard && nodes_[slot].nmt == NmtState::kOperational;
    };
    const auto drive_done = [&](std::size_t d) { return !enable_drives || in.drives[d].ready; };
    const bool done = cycle_until(clock, out, in, [&] {
      for (std::size_t slot = 0; slot < kNodeCount; ++slot) {
        if (!node_answered(slot) || !node_operational(slot) ||
            (slot < kDriveCount && !drive_done(slot))) {
          return false;
        }
      }
      return true;
    });
    if (!done) {
      const std::string within = " within " + std::to_string(config_.enable_timeout_ms) + " ms";
      for (std::size_t slot = 0; slot < kNodeCount; ++slot) {
        if (!node_answered(slot)) {
          report.problems.push_back(node_label(slot) + ": no process data" + within);
        } else if (!node_operational(slot)) {
          report.problems.push_back(node_label(slot) + ": no heartbeat reporting operational" +
                                    within + ", state " + std::string(to_string(nodes_[slot].nmt)));
        } else if (slot < kDriveCount && !drive_done(slot)) {
          report.problems.push_back(node_label(slot) + ": not in operation enabled" + within +
                                    ", state " + cia402::to_string(drives_[slot].state));
        }
      }
      configured = false;
    }
  }
  report.ok = configured && report.problems.empty();
  report.duration_ns = clock.now_ns() - started_ns;
  // The SDO transfers' pauses are not the cycle's timing: measure from here.
  take_send_confirmations();
  bus_timing_ = CanBusTiming{};
  last_sync_sent_ns_ = 0;
  last_sync_queued_ns_ = 0;
  return report;
}

bool CanopenIo::shut_down(const BusClock& clock) {
  InputImage in{};
  const bool disabled = cycle_until(clock, OutputImage{}, in, [this] {
    return std::none_of(drives_.begin(), drives_.end(), [](const DriveRuntime& drive) {
      return drive.state == cia402::State::kOperationEnabled;
    });
  });
  if (!bus_.send(canopen::make_nmt(canopen::NmtCommand::kStop, canopen::kAllNodes))) {
    ++counters_.send_failures;
    return false;
  }
  nmt_commanded_ = true;  // the stopped heartbeats that follow were asked for
  return disabled;
}

}  // namespace fl::drivers
