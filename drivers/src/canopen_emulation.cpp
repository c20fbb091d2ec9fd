#include "fl/drivers/canopen_emulation.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace fl::drivers::emulation {

using canopen::NmtCommand;
using canopen::NmtState;
using canopen::NodeId;
using canopen::SdoAddress;
namespace sdo_abort = canopen::sdo_abort;

namespace {
constexpr std::uint16_t kRpdoCommunication = 0x1400;
constexpr std::uint16_t kRpdoMapping = 0x1600;
constexpr std::uint16_t kTpdoCommunication = 0x1800;
constexpr std::uint16_t kTpdoMapping = 0x1A00;
constexpr std::size_t kPdoCount = 4;
constexpr std::uint8_t kMaxSynchronousType = 240;  // 1..240: every n-th SYNC
constexpr std::uint16_t kConsumerHeartbeat = 0x1016;
constexpr std::uint16_t kErrorBehaviour = 0x1029;
// CiA 301 error behaviour 0x1029:01 on a communication error.
constexpr std::uint32_t kToPreOperational = 0;
constexpr std::uint32_t kToStopped = 2;
// EMCY "life guard error or heartbeat error" (CiA 301 table 26), error register bit 4
// (communication error).
constexpr std::uint16_t kHeartbeatErrorCode = 0x8130;
constexpr std::uint8_t kCommunicationErrorRegister = 0x11;
}  // namespace

// ---------------------------------------------------------------- EmulatedNode

EmulatedNode::EmulatedNode(NodeId node, std::uint32_t device_type, std::string device_name)
    : node_(node), device_name_(std::move(device_name)) {
  add({0x1000, 0, 4, false, device_type});
  add({0x1001, 0, 1, false, 0});  // error register
  add_communication_objects();
}

void EmulatedNode::add_communication_objects() {
  add({0x1017, 0, 2, true, 0});  // heartbeat producer time, off until configured
  // One consumed heartbeat (the master's): producer node in bits 16..23, time in ms in bits
  // 0..15; 0 is off, as from the factory.
  add({kConsumerHeartbeat, 0, 1, false, 1});
  add({kConsumerHeartbeat, 1, 4, true, 0});
  add({kErrorBehaviour, 0, 1, false, 1});
  add({kErrorBehaviour, 1, 1, true, kToPreOperational});
  for (std::size_t n = 0; n < kPdoCount; ++n) {
    const auto offset = static_cast<std::uint16_t>(n);
    // Predefined connection set COB-IDs, valid, with empty mappings: the master must map.
    add({static_cast<std::uint16_t>(kRpdoCommunication + offset), 1, 4, true,
         canopen::kRpdoBase[n] + node_});
    add({static_cast<std::uint16_t>(kRpdoCommunication + offset), 2, 1, true, 255});
    add({static_cast<std::uint16_t>(kTpdoCommunication + offset), 1, 4, true,
         canopen::kTpdoBase[n] + node_});
    add({static_cast<std::uint16_t>(kTpdoCommunication + offset), 2, 1, true, 255});
    for (std::uint8_t sub = 0; sub <= canopen::kMaxPdoEntries; ++sub) {
      const std::uint8_t size = sub == 0 ? 1 : 4;
      add({static_cast<std::uint16_t>(kRpdoMapping + offset), sub, size, true, 0});
      add({static_cast<std::uint16_t>(kTpdoMapping + offset), sub, size, true, 0});
    }
  }
}

void EmulatedNode::add(ObjectEntry entry) {
  objects_.push_back(entry);
  defaults_.push_back(entry);
}

const ObjectEntry* EmulatedNode::find(std::uint16_t index, std::uint8_t subindex) const {
  for (const ObjectEntry& entry : objects_) {
    if (entry.index == index && entry.subindex == subindex) {
      return &entry;
    }
  }
  return nullptr;
}

ObjectEntry* EmulatedNode::find(std::uint16_t index, std::uint8_t subindex) {
  return const_cast<ObjectEntry*>(std::as_const(*this).find(index, subindex));
}

std::uint32_t EmulatedNode::value(std::uint16_t index, std::uint8_t subindex) const {
  const ObjectEntry* entry = find(index, subindex);
  return entry != nullptr ? entry->value : 0U;
}

void EmulatedNode::set_value(std::uint16_t index, std::uint8_t subindex, std::uint32_t value) {
  ObjectEntry* entry = find(index, subindex);
  if (entry != nullptr) {
    const std::uint32_t mask =
        entry->size_bytes >= 4 ? 0xFFFFFFFFU : ((1U << (8U * entry->size_bytes)) - 1U);
    entry->value = value & mask;
  }
}

void EmulatedNode::power_cycle() {
  objects_ = defaults_;
  reset_application();
  nmt_ = NmtState::kPreOperational;
  boot_pending_ = true;
  sync_counters_ = {};
  rpdo_pending_ = {};
  upload_active_ = false;
  consumer_armed_ = false;
  heartbeat_error_ = false;
}

void EmulatedNode::fix_mapping(std::uint16_t mapping_index, const canopen::PdoMapping& mapping) {
  for (std::size_t i = 0; i < defaults_.size(); ++i) {
    ObjectEntry& entry = defaults_[i];
    if (entry.index != mapping_index) continue;
    entry.writable = false;
    entry.value = entry.subindex == 0 ? mapping.count
                  : entry.subindex <= mapping.count
                      ? mapping.entries[entry.subindex - 1U].mapping_value()
                      : 0U;
    objects_[i] = entry;
  }
}

void EmulatedNode::reset_communication() {
  for (std::size_t i = 0; i < objects_.size(); ++i) {
    if (objects_[i].index >= 0x1000 && objects_[i].index <= 0x1FFF) {
      objects_[i] = defaults_[i];
    }
  }
  nmt_ = NmtState::kPreOperational;
  boot_pending_ = true;
  sync_counters_ = {};
  rpdo_pending_ = {};
  upload_active_ = false;
  consumer_armed_ = false;
  heartbeat_error_ = false;
}

void EmulatedNode::send(CanBus& bus, const CanFrame& frame) {
  if (!silent_) {
    bus.send(frame);
  }
}

void EmulatedNode::send_emcy(CanBus& bus, std::uint16_t code, std::uint8_t error_register) {
  set_value(0x1001, 0, error_register);
  send(bus, canopen::make_emcy(node_, canopen::Emergency{code, error_register, {}}));
}

void EmulatedNode::tick(CanBus& bus, std::int64_t now_ns) {
  if (silent_) {
    return;
  }
  const std::int64_t consumer_ns = std::int64_t{value(kConsumerHeartbeat, 1) & 0xFFFFU} * 1'000'000;
  if (consumer_armed_ && consumer_ns > 0 && now_ns - last_consumed_heartbeat_ns_ > consumer_ns) {
    consumer_armed_ = false;  // until the producer is heard again
    heartbeat_lost(bus);
  }
  if (boot_pending_) {
    boot_pending_ = false;
    last_heartbeat_ns_ = now_ns;
    send(bus, canopen::make_heartbeat(node_, NmtState::kBootUp));
    return;
  }
  const std::int64_t period_ns = std::int64_t{value(0x1017, 0)} * 1'000'000;
  if (period_ns > 0 && now_ns - last_heartbeat_ns_ >= period_ns) {
    last_heartbeat_ns_ = now_ns;
    send(bus, canopen::make_heartbeat(node_, nmt_));
  }
}

void EmulatedNode::heartbeat_lost(CanBus& bus) {
  ++counters_.heartbeats_lost;
  if (nmt_ != NmtState::kStopped) {  // no EMCY while stopped (CiA 301 7.3.2)
    heartbeat_error_ = true;
    send_emcy(bus, kHeartbeatErrorCode, kCommunicationErrorRegister);
  }
  const std::uint32_t behaviour = value(kErrorBehaviour, 1);
  if (behaviour == kToPreOperational && nmt_ == NmtState::kOperational) {
    nmt_ = NmtState::kPreOperational;
  } else if (behaviour == kToStopped) {
    nmt_ = NmtState::kStopped;
  }
  on_heartbeat_lost();
}

void EmulatedNode::handle(CanBus& bus, const CanFrame& frame, std::int64_t now_ns) {
  if (silent_ || frame.extended || frame.remote) {
    return;
  }
  const std::uint32_t consumer = value(kConsumerHeartbeat, 1);
  const std::uint32_t producer = (consumer >> 16U) & 0x7FU;
  if ((consumer & 0xFFFFU) != 0U && producer != 0U &&
      frame.id == canopen::kHeartbeatBase + producer && frame.dlc >= 1) {
    consumer_armed_ = true;  // monitoring starts with the first heartbeat (CiA 301 7.2.8.3.2.2)
    last_consumed_heartbeat_ns_ = now_ns;
    if (heartbeat_error_ && nmt_ != NmtState::kStopped) {
      heartbeat_error_ = false;
      send_emcy(bus, 0x0000, 0x00);  // the error is gone: error reset
    }
    return;
  }
  if (frame.id == canopen::kNmtCobId) {
    if (frame.dlc != 2 || (frame.data[1] != canopen::kAllNodes && frame.data[1] != node_)) {
      return;
    }
    const auto command = canopen::decode_nmt_command(frame.data[0]);
    if (!command) {
      return;
    }
    switch (*command) {
      case NmtCommand::kStart:
        nmt_ = NmtState::kOperational;
        break;
      case NmtCommand::kStop:
        nmt_ = NmtState::kStopped;
        break;
      case NmtCommand::kEnterPreOperational:
        nmt_ = NmtState::kPreOperational;
        break;
      case NmtCommand::kResetNode:
        power_cycle();
        break;
      case NmtCommand::kResetCommunication:
        reset_communication();
        break;
    }
    return;
  }
  if (nmt_ == NmtState::kStopped) {
    return;  // only NMT (and the heartbeat) work while stopped
  }
  if (frame.id == canopen::kSdoRequestBase + node_) {
    handle_sdo(bus, frame);
    return;
  }
  if (nmt_ != NmtState::kOperational) {
    return;  // no PDO and no SYNC in pre-operational
  }
  if (frame.id == canopen::kSyncCobId) {
    ++counters_.syncs;
    for (std::size_t n = 0; n < kPdoCount; ++n) {
      if (rpdo_pending_[n]) {
        apply_rpdo(n);
      }
    }
    on_sync(bus, now_ns);
    send_tpdos(bus);
    return;
  }
  for (std::size_t n = 0; n < kPdoCount; ++n) {
    const std::uint32_t cob = value(static_cast<std::uint16_t>(kRpdoCommunication + n), 1);
    if ((cob & canopen::kPdoCobIdInvalid) == 0U && (cob & kCanStandardIdMask) == frame.id) {
      handle_rpdo(n, frame);
      return;
    }
  }
}

canopen::PdoMapping EmulatedNode::mapping(std::uint16_t mapping_index) const {
  canopen::PdoMapping result;
  result.count = static_cast<std::uint8_t>(
      std::min<std::uint32_t>(value(mapping_index, 0), canopen::kMaxPdoEntries));
  for (std::uint8_t i = 0; i < result.count; ++i) {
    result.entries[i] = canopen::PdoEntry::from_mapping_value(
        value(mapping_index, static_cast<std::uint8_t>(i + 1)));
  }
  return result;
}

void EmulatedNode::handle_rpdo(std::size_t pdo, const CanFrame& frame) {
  const canopen::PdoMapping map = mapping(static_cast<std::uint16_t>(kRpdoMapping + pdo));
  if (frame.dlc < map.bytes() || map.count == 0) {
    ++counters_.refused_rpdos;  // CiA 301: too short is not processed (EMCY 0x8210)
    return;
  }
  ++counters_.rpdos;
  const auto type =
      static_cast<std::uint8_t>(value(static_cast<std::uint16_t>(kRpdoCommunication + pdo), 2));
  pending_rpdo_[pdo] = frame;
  if (type <= kMaxSynchronousType) {
    rpdo_pending_[pdo] = true;  // applied at the next SYNC
  } else {
    apply_rpdo(pdo);
  }
}

void EmulatedNode::apply_rpdo(std::size_t pdo) {
  rpdo_pending_[pdo] = false;
  const canopen::PdoMapping map = mapping(static_cast<std::uint16_t>(kRpdoMapping + pdo));
  std::size_t offset = 0;
  for (std::uint8_t i = 0; i < map.count; ++i) {
    const std::size_t bytes = map.entries[i].bits / 8U;
    const std::uint32_t raw = get_le(pending_rpdo_[pdo].data, offset, bytes);
    offset += bytes;
    set_value(map.entries[i].index, map.entries[i].subindex, raw);
    on_write(map.entries[i].index, map.entries[i].subindex);
  }
}

void EmulatedNode::send_tpdos(CanBus& bus) {
  for (std::size_t n = 0; n < kPdoCount; ++n) {
    const auto communication = static_cast<std::uint16_t>(kTpdoCommunication + n);
    const std::uint32_t cob = value(communication, 1);
    const auto type = static_cast<std::uint8_t>(value(communication, 2));
    const canopen::PdoMapping map = mapping(static_cast<std::uint16_t>(kTpdoMapping + n));
    if ((cob & canopen::kPdoCobIdInvalid) != 0U || type == 0 || type > kMaxSynchronousType ||
        map.count == 0) {
      continue;
    }
    if (++sync_counters_[n] < type) {
      continue;
    }
    sync_counters_[n] = 0;
    std::array<std::uint32_t, canopen::kMaxPdoEntries> values{};
    for (std::uint8_t i = 0; i < map.count; ++i) {
      values[i] = value(map.entries[i].index, map.entries[i].subindex);
    }
    ++counters_.tpdos;
    send(bus, canopen::pack_pdo(cob & kCanStandardIdMask, map,
                                std::span<const std::uint32_t>(values.data(), map.count)));
  }
}

void EmulatedNode::handle_sdo(CanBus& bus, const CanFrame& frame) {
  ++counters_.sdo_requests;
  const canopen::SdoRequest request = canopen::decode_sdo_request(frame);
  const std::uint32_t response_id = canopen::kSdoResponseBase + node_;
  const auto abort = [&](SdoAddress address, std::uint32_t code) {
    ++counters_.sdo_aborts_sent;
    upload_active_ = false;
    send(bus, canopen::make_sdo_abort(response_id, address, code));
  };
  switch (request.kind) {
    case canopen::SdoRequestKind::kInvalid:
      abort({}, sdo_abort::kCommandSpecifier);
      return;
    case canopen::SdoRequestKind::kAbort:
      upload_active_ = false;
      return;
    case canopen::SdoRequestKind::kDownloadSegmented:
      abort(request.address, sdo_abort::kUnsupportedAccess);  // expedited only
      return;
    case canopen::SdoRequestKind::kUploadSegment: {
      if (!upload_active_) {
        abort({}, sdo_abort::kCommandSpecifier);
        return;
      }
      if (request.toggle != upload_toggle_) {
        abort({}, sdo_abort::kToggleBit);
        return;
      }
      const std::size_t remaining = upload_data_.size() - upload_offset_;
      const std::size_t count = std::min<std::size_t>(remaining, 7);
      const bool last = count == remaining;
      const auto* bytes = reinterpret_cast<const std::uint8_t*>(upload_data_.data());
      send(bus, canopen::make_sdo_upload_segment(
                    node_, upload_toggle_,
                    std::span<const std::uint8_t>(bytes + upload_offset_, count), last));
      upload_offset_ += count;
      upload_toggle_ = !upload_toggle_;
      upload_active_ = !last;
      return;
    }
    case canopen::SdoRequestKind::kUpload: {
      if (request.address.index == 0x1008 && request.address.subindex == 0) {
        upload_data_ = device_name_;
        upload_offset_ = 0;
        upload_toggle_ = false;
        upload_active_ = true;
        send(bus, canopen::make_sdo_upload_segmented_response(
                      node_, request.address, static_cast<std::uint32_t>(upload_data_.size())));
        return;
      }
      const ObjectEntry* entry = find(request.address.index, request.address.subindex);
      if (entry == nullptr) {
        const bool index_exists =
            std::any_of(objects_.begin(), objects_.end(),
                        [&](const ObjectEntry& e) { return e.index == request.address.index; });
        abort(request.address, index_exists ? sdo_abort::kNoSubindex : sdo_abort::kNoObject);
        return;
      }
      send(bus, canopen::make_sdo_upload_expedited_response(node_, request.address, entry->value,
                                                            entry->size_bytes));
      return;
    }
    case canopen::SdoRequestKind::kDownloadExpedited: {
      ObjectEntry* entry = find(request.address.index, request.address.subindex);
      if (entry == nullptr) {
        const bool index_exists =
            std::any_of(objects_.begin(), objects_.end(),
                        [&](const ObjectEntry& e) { return e.index == request.address.index; });
        abort(request.address, index_exists ? sdo_abort::kNoSubindex : sdo_abort::kNoObject);
        return;
      }
      if (!entry->writable) {
        abort(request.address, sdo_abort::kReadOnly);
        return;
      }
      if (request.size_bytes != 0 && request.size_bytes != entry->size_bytes) {
        abort(request.address, sdo_abort::kLengthMismatch);
        return;
      }
      const std::uint16_t index = request.address.index;
      const bool is_mapping = (index >= kRpdoMapping && index < kRpdoMapping + kPdoCount) ||
                              (index >= kTpdoMapping && index < kTpdoMapping + kPdoCount);
      if (is_mapping) {
        // A mapping changes only while its PDO is invalid (CiA 301, 7.5.2.36).
        const auto communication = static_cast<std::uint16_t>(index - 0x200);
        if ((value(communication, 1) & canopen::kPdoCobIdInvalid) == 0U) {
          abort(request.address, sdo_abort::kDeviceState);
          return;
        }
        if (request.address.subindex == 0) {
          if (request.value > canopen::kMaxPdoEntries) {
            abort(request.address, sdo_abort::kValueTooHigh);
            return;
          }
          canopen::PdoMapping candidate;
          candidate.count = static_cast<std::uint8_t>(request.value);
          for (std::uint8_t i = 0; i < candidate.count; ++i) {
            candidate.entries[i] = canopen::PdoEntry::from_mapping_value(
                value(index, static_cast<std::uint8_t>(i + 1)));
            const canopen::PdoEntry mapped = candidate.entries[i];
            if (find(mapped.index, mapped.subindex) == nullptr) {
              abort(request.address, sdo_abort::kNotMappable);
              return;
            }
          }
          if (!candidate.valid()) {
            abort(request.address, sdo_abort::kPdoLengthExceeded);
            return;
          }
        }
      }
      set_value(request.address.index, request.address.subindex, request.value);
      if (request.address.index == kConsumerHeartbeat) {
        consumer_armed_ = false;  // a new consumer time waits for the next heartbeat
      }
      on_write(request.address.index, request.address.subindex);
      send(bus, canopen::make_sdo_download_response(node_, request.address));
      return;
    }
  }
}

// ---------------------------------------------------------------- CiA 402 drive

EmulatedCia402Drive::EmulatedCia402Drive(NodeId node, double counts_per_velocity_unit_s)
    // Device type 0x00020192: CiA 402, servo drive (CiA 402-2, 6.2).
    : EmulatedNode(node, 0x00020192, "FL emulated CiA 402 drive"),
      counts_per_velocity_unit_s_(counts_per_velocity_unit_s) {
  add({0x603F, 0, 2, false, 0});
  add({0x6040, 0, 2, true, 0});
  add({0x6041, 0, 2, false, 0});
  add({0x6060, 0, 1, true, 0});
  add({0x6061, 0, 1, false, 0});
  add({0x6064, 0, 4, false, 0});
  add({0x606C, 0, 4, false, 0});
  add({0x6007, 0, 2, true, 0});  // abort connection option: none until configured
  add({0x6083, 0, 4, true, 1});
  add({0x6084, 0, 4, true, 1});
  add({0x6085, 0, 4, true, 1});
  add({0x60FF, 0, 4, true, 0});
  publish();
}

void EmulatedCia402Drive::reset_application() {
  state_ = DriveState{};
  last_controlword_ = 0;
  position_remainder_ = 0.0;
  last_sync_ns_ = 0;
  publish();
}

void EmulatedCia402Drive::inject_fault(std::uint16_t error_code) {
  state_.error_code = error_code;
  state_.state = cia402::State::kFaultReactionActive;
  fault_emcy_pending_ = true;
  publish();
}

void EmulatedCia402Drive::on_write(std::uint16_t index, std::uint8_t /*subindex*/) {
  switch (index) {
    case 0x6040: {
      const auto controlword = static_cast<std::uint16_t>(value(0x6040, 0));
      const cia402::Command command = cia402::decode_controlword(controlword, last_controlword_);
      last_controlword_ = controlword;
      const cia402::State before = state_.state;
      state_.state = cia402::next_state(state_.state, command);
      if (before == cia402::State::kFault && state_.state != cia402::State::kFault) {
        state_.error_code = 0;
        clear_emcy_pending_ = true;  // EMCY 0x0000: error reset
      }
      break;
    }
    case 0x6060:
      state_.mode = static_cast<std::int8_t>(sign_extend(value(0x6060, 0), 8));
      set_value(0x6061, 0, value(0x6060, 0));
      break;
    case 0x60FF:
      state_.target_velocity = sign_extend(value(0x60FF, 0), 32);
      break;
    case 0x6083:
      state_.acceleration = std::max<std::uint32_t>(value(0x6083, 0), 1);
      break;
    case 0x6084:
      state_.deceleration = std::max<std::uint32_t>(value(0x6084, 0), 1);
      break;
    case 0x6085:
      state_.quick_stop_deceleration = std::max<std::uint32_t>(value(0x6085, 0), 1);
      break;
    default:
      break;
  }
  publish();
}

void EmulatedCia402Drive::on_heartbeat_lost() {
  // CiA 402 0x6007: 1 fault signal, 2 disable voltage, 3 quick stop (the others are
  // manufacturer specific or none).
  const auto option = static_cast<std::int16_t>(sign_extend(value(0x6007, 0), 16));
  const bool powered = state_.state == cia402::State::kOperationEnabled ||
                       state_.state == cia402::State::kSwitchedOn ||
                       state_.state == cia402::State::kReadyToSwitchOn;
  if (option == 1) {
    inject_fault(kHeartbeatErrorCode);
  } else if (option == 2 && powered) {
    state_.state = cia402::State::kSwitchOnDisabled;  // the motor coasts
  } else if (option == 3 && state_.state == cia402::State::kOperationEnabled) {
    state_.state = cia402::State::kQuickStopActive;
  }
  publish();
}

void EmulatedCia402Drive::on_sync(CanBus& bus, std::int64_t now_ns) {
  const double dt_s = last_sync_ns_ == 0 ? 0.0 : static_cast<double>(now_ns - last_sync_ns_) / 1e9;
  last_sync_ns_ = now_ns;
  if (fault_emcy_pending_) {
    fault_emcy_pending_ = false;
    send_emcy(bus, state_.error_code, 0x01);  // error register bit 0: generic error
  }
  if (clear_emcy_pending_) {
    clear_emcy_pending_ = false;
    send_emcy(bus, 0x0000, 0x00);
  }
  const bool following = state_.state == cia402::State::kOperationEnabled && state_.mode == 3;
  if (plant_) {
    if (!following) {
      state_.target_velocity = 0;
    }
    plant_(state_, dt_s);
  } else {
    // Built-in ramp: accelerate towards |target|, decelerate towards zero.
    const double target = following ? static_cast<double>(state_.target_velocity) : 0.0;
    const double current = static_cast<double>(state_.velocity_actual);
    const bool speeding_up = std::fabs(target) > std::fabs(current) && target * current >= 0.0;
    const double rate = static_cast<double>(state_.state == cia402::State::kQuickStopActive
                                                ? state_.quick_stop_deceleration
                                            : speeding_up ? state_.acceleration
                                                          : state_.deceleration);
    const double step = rate * dt_s;
    const double next = current + std::clamp(target - current, -step, step);
    state_.velocity_actual = static_cast<std::int32_t>(std::llround(next));
    const double travel =
        (current + next) / 2.0 * dt_s * counts_per_velocity_unit_s_ + position_remainder_;
    const double whole = std::trunc(travel);
    position_remainder_ = travel - whole;
    state_.position_actual += static_cast<std::int64_t>(whole);
  }
  // Quick stop and fault reaction end when the motor stands (transitions 12 and 14).
  if (state_.velocity_actual == 0) {
    if (state_.state == cia402::State::kQuickStopActive) {
      state_.state = cia402::State::kSwitchOnDisabled;
    } else if (state_.state == cia402::State::kFaultReactionActive) {
      state_.state = cia402::State::kFault;
    }
  }
  publish();
}

void EmulatedCia402Drive::publish() {
  std::uint16_t statusword = cia402::statusword_bits(state_.state);
  if (state_.velocity_actual == state_.target_velocity) {
    statusword |= 0x0400;  // bit 10: target reached
  }
  set_value(0x6041, 0, statusword);
  set_value(0x6064, 0,
            static_cast<std::uint32_t>(static_cast<std::uint64_t>(state_.position_actual)));
  set_value(0x606C, 0, to_wire(state_.velocity_actual));
  set_value(0x603F, 0, state_.error_code);
}

// ---------------------------------------------------------------- CiA 401 I/O

EmulatedCia401Io::EmulatedCia401Io(NodeId node)
    // Device type 0x000F0191: CiA 401 with digital/analogue inputs and outputs.
    : EmulatedNode(node, 0x000F0191, "FL emulated CiA 401 I/O") {
  add({0x6000, 1, 1, false, 0});
  add({0x6200, 1, 1, true, 0});
  for (std::uint8_t channel = 1; channel <= 3; ++channel) {
    add({0x6401, channel, 2, false, 0});
    add({0x6411, channel, 2, true, 0});
  }
  // Output error modes and values (CiA 401): what the outputs become on a communication error.
  // Digital: every output to its error value, all off (CiA 401's defaults). Analogue: kept
  // unless configured.
  add({0x6206, 1, 1, true, 0xFF});
  add({0x6207, 1, 1, true, 0x00});
  for (std::uint8_t channel = 1; channel <= 3; ++channel) {
    add({0x6443, channel, 1, true, 0});
    add({0x6444, channel, 4, true, 0});
  }
}

void EmulatedCia401Io::on_heartbeat_lost() {
  const auto mode = static_cast<std::uint8_t>(value(0x6206, 1));
  const auto error_value = static_cast<std::uint8_t>(value(0x6207, 1));
  state_.digital_outputs =
      static_cast<std::uint8_t>((state_.digital_outputs & ~mode) | (error_value & mode));
  for (std::uint8_t channel = 1; channel <= 3; ++channel) {
    if (value(0x6443, channel) != 0U) {
      state_.analog_outputs[channel - 1U] =
          static_cast<std::int16_t>(sign_extend(value(0x6444, channel), 32));
    }
  }
}

void EmulatedCia401Io::reset_application() {
  const IoState inputs = state_;
  state_ = IoState{};
  // The field wiring does not change with a reset: inputs stay.
  state_.digital_inputs = inputs.digital_inputs;
  state_.analog_inputs = inputs.analog_inputs;
}

void EmulatedCia401Io::on_write(std::uint16_t index, std::uint8_t subindex) {
  if (index == 0x6200 && subindex == 1) {
    state_.digital_outputs = static_cast<std::uint8_t>(value(0x6200, 1));
  } else if (index == 0x6411 && subindex >= 1 && subindex <= 3) {
    state_.analog_outputs[subindex - 1U] =
        static_cast<std::int16_t>(sign_extend(value(0x6411, subindex), 16));
  }
}

void EmulatedCia401Io::on_sync(CanBus& /*bus*/, std::int64_t /*now_ns*/) {
  set_value(0x6000, 1, state_.digital_inputs);
  for (std::uint8_t channel = 1; channel <= 3; ++channel) {
    set_value(0x6401, channel, to_wire(state_.analog_inputs[channel - 1U]) & 0xFFFFU);
  }
}

// ---------------------------------------------------------------- EmulatedBusNodes

EmulatedCia402Drive& EmulatedBusNodes::add_drive(NodeId node, double counts_per_velocity_unit_s) {
  auto drive = std::make_unique<EmulatedCia402Drive>(node, counts_per_velocity_unit_s);
  EmulatedCia402Drive& result = *drive;
  nodes_.push_back(std::move(drive));
  return result;
}

EmulatedCia401Io& EmulatedBusNodes::add_io(NodeId node) {
  auto io = std::make_unique<EmulatedCia401Io>(node);
  EmulatedCia401Io& result = *io;
  nodes_.push_back(std::move(io));
  return result;
}

void EmulatedBusNodes::poll(std::int64_t now_ns) {
  while (true) {
    const std::size_t count = bus_.receive(batch_);
    for (std::size_t i = 0; i < count; ++i) {
      for (const auto& node : nodes_) {
        node->handle(bus_, batch_[i], now_ns);
      }
    }
    if (count < batch_.size()) {
      break;
    }
  }
  for (const auto& node : nodes_) {
    node->tick(bus_, now_ns);
  }
}

}  // namespace fl::drivers::emulation
