#include "fl/drivers/canopen_cia402.hpp"

namespace fl::drivers::cia402 {

const char* to_string(State state) {
  switch (state) {
    case State::kNotReadyToSwitchOn:
      return "not ready to switch on";
    case State::kSwitchOnDisabled:
      return "switch on disabled";
    case State::kReadyToSwitchOn:
      return "ready to switch on";
    case State::kSwitchedOn:
      return "switched on";
    case State::kOperationEnabled:
      return "operation enabled";
    case State::kQuickStopActive:
      return "quick stop active";
    case State::kFaultReactionActive:
      return "fault reaction active";
    case State::kFault:
      return "fault";
    case State::kUnknown:
      break;
  }
  return "unknown";
}

State decode_statusword(std::uint16_t statusword) {
  // Bits 0 ready to switch on, 1 switched on, 2 operation enabled, 3 fault, 5 quick stop,
  // 6 switch on disabled. The 0x4F patterns ignore bit 5, the 0x6F patterns need it.
  const unsigned low7 = statusword & 0x6FU;
  switch (statusword & 0x4FU) {
    case 0x00:
      return State::kNotReadyToSwitchOn;
    case 0x40:
      return State::kSwitchOnDisabled;
    case 0x0F:
      return State::kFaultReactionActive;
    case 0x08:
      return State::kFault;
    default:
      break;
  }
  switch (low7) {
    case 0x21:
      return State::kReadyToSwitchOn;
    case 0x23:
      return State::kSwitchedOn;
    case 0x27:
      return State::kOperationEnabled;
    case 0x07:
      return State::kQuickStopActive;
    default:
      return State::kUnknown;
  }
}

std::uint16_t statusword_bits(State state) {
  constexpr std::uint16_t kVoltageEnabled = 0x0010;
  constexpr std::uint16_t kRemote = 0x0200;  // controlled over the bus
  switch (state) {
    case State::kNotReadyToSwitchOn:
      return 0x0000;
    case State::kSwitchOnDisabled:
      return 0x0040 | kRemote;
    case State::kReadyToSwitchOn:
      return 0x0021 | kRemote;
    case State::kSwitchedOn:
      return 0x0023 | kVoltageEnabled | kRemote;
    case State::kOperationEnabled:
      return 0x0027 | kVoltageEnabled | kRemote;
    case State::kQuickStopActive:
      return 0x0007 | kVoltageEnabled | kRemote;
    case State::kFaultReactionActive:
      return 0x000F | kVoltageEnabled | kRemote;
    case State::kFault:
      return 0x0008 | kRemote;
    case State::kUnknown:
      break;
  }
  return 0x0000;
}

Command decode_controlword(std::uint16_t controlword, std::uint16_t previous) {
  const bool reset_bit = (controlword & 0x0080U) != 0U;
  const bool previous_reset_bit = (previous & 0x0080U) != 0U;
  if (reset_bit) {
    // Rising edge: fault reset; bit 7 held high: no command (CiA 402 table 28).
    return previous_reset_bit ? Command::kNone : Command::kFaultReset;
  }
  if ((controlword & 0x0002U) == 0U) {
    return Command::kDisableVoltage;  // x x 0 x
  }
  if ((controlword & 0x0004U) == 0U) {
    return Command::kQuickStop;  // x 0 1 x
  }
  switch (controlword & 0x000FU) {
    case 0x06:
    case 0x0E:
      return Command::kShutdown;  // x 1 1 0
    case 0x07:
      return Command::kSwitchOn;  // 0 1 1 1
    case 0x0F:
      return Command::kSwitchOnAndEnable;  // 1 1 1 1
    default:
      return Command::kNone;
  }
}

State next_state(State current, Command command) {
  switch (current) {
    case State::kSwitchOnDisabled:
      return command == Command::kShutdown ? State::kReadyToSwitchOn : current;  // 2
    case State::kReadyToSwitchOn:
      switch (command) {
        case Command::kSwitchOn:
          return State::kSwitchedOn;  // 3
        case Command::kSwitchOnAndEnable:
          return State::kOperationEnabled;  // 3 + 4
        case Command::kDisableVoltage:
        case Command::kQuickStop:
          return State::kSwitchOnDisabled;  // 7
        default:
          return current;
      }
    case State::kSwitchedOn:
      switch (command) {
        case Command::kSwitchOnAndEnable:
          return State::kOperationEnabled;  // 4
        case Command::kShutdown:
          return State::kReadyToSwitchOn;  // 6
        case Command::kDisableVoltage:
        case Command::kQuickStop:
          return State::kSwitchOnDisabled;  // 10
        default:
          return current;
      }
    case State::kOperationEnabled:
      switch (command) {
        case Command::kSwitchOn:
          return State::kSwitchedOn;  // 5 (disable operation)
        case Command::kShutdown:
          return State::kReadyToSwitchOn;  // 8
        case Command::kDisableVoltage:
          return State::kSwitchOnDisabled;  // 9
        case Command::kQuickStop:
          return State::kQuickStopActive;  // 11
        default:
          return current;
      }
    case State::kQuickStopActive:
      switch (command) {
        case Command::kDisableVoltage:
          return State::kSwitchOnDisabled;  // 12
        case Command::kSwitchOnAndEnable:
          return State::kOperationEnabled;  // 16 (quick stop option codes 5..8)
        default:
          return current;
      }
    case State::kFault:
      return command == Command::kFaultReset ? State::kSwitchOnDisabled : current;  // 15
    case State::kNotReadyToSwitchOn:
    case State::kFaultReactionActive:
    case State::kUnknown:
      return current;  // the device leaves these by itself (transitions 1 and 14)
  }
  return current;
}

std::uint16_t master_controlword(State state, Goal goal, bool reset_fault, bool reset_phase) {
  using namespace controlword;
  switch (state) {
    case State::kFault:
      return reset_fault && reset_phase ? kFaultReset : kDisableVoltage;
    case State::kFaultReactionActive:
    case State::kNotReadyToSwitchOn:
    case State::kUnknown:
      return kDisableVoltage;
    case State::kSwitchOnDisabled:
      return goal == Goal::kQuickStop ? kDisableVoltage : kShutdown;  // -> 2
    case State::kReadyToSwitchOn:
      return goal == Goal::kQuickStop ? kDisableVoltage : kSwitchOn;  // -> 3
    case State::kSwitchedOn:
      switch (goal) {
        case Goal::kOperationEnabled:
          return kEnableOperation;  // -> 4
        case Goal::kSwitchedOn:
          return kSwitchOn;  // hold
        case Goal::kQuickStop:
          return kQuickStop;  // -> 10
      }
      break;
    case State::kOperationEnabled:
      switch (goal) {
        case Goal::kOperationEnabled:
          return kEnableOperation;  // hold
        case Goal::kSwitchedOn:
          return kDisableOperation;  // -> 5: the drive ramps down by its own option code
        case Goal::kQuickStop:
          return kQuickStop;  // -> 11
      }
      break;
    case State::kQuickStopActive:
      // Stay in quick stop until the drive finishes it (-> 12 by itself); a wanted restart
      // goes through Switch On Disabled so that the line's start sequence applies.
      return goal == Goal::kQuickStop ? kQuickStop : kDisableVoltage;
  }
  return kDisableVoltage;
}

}  // namespace fl::drivers::cia402
