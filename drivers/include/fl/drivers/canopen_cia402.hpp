// CiA 402 (IEC 61800-7-201) power drive state machine: statusword decoding, controlword
// commands, the device-side transition table (for the emulated drive) and the master's
// choice of controlword to step a drive towards the state it wants.
#pragma once

#include <cstdint>

namespace fl::drivers::cia402 {

enum class State : std::uint8_t {
  kNotReadyToSwitchOn,
  kSwitchOnDisabled,
  kReadyToSwitchOn,
  kSwitchedOn,
  kOperationEnabled,
  kQuickStopActive,
  kFaultReactionActive,
  kFault,
  kUnknown,  // a statusword pattern the standard does not define
};
const char* to_string(State state);

// Statusword bits 0..3, 5, 6 per CiA 402 table 30 ("x" bits masked out).
State decode_statusword(std::uint16_t statusword);
// The defining bits of `state` (bit 4 voltage enabled and bit 9 remote set where a real
// drive sets them), for the emulated drive.
std::uint16_t statusword_bits(State state);

namespace controlword {
// Bits: 0 switch on, 1 enable voltage, 2 quick stop (active low), 3 enable operation,
// 7 fault reset (rising edge).
inline constexpr std::uint16_t kShutdown = 0x0006;
inline constexpr std::uint16_t kSwitchOn = 0x0007;
inline constexpr std::uint16_t kDisableOperation = 0x0007;  // same bits, from Operation Enabled
inline constexpr std::uint16_t kEnableOperation = 0x000F;   // also "switch on + enable"
inline constexpr std::uint16_t kDisableVoltage = 0x0000;
inline constexpr std::uint16_t kQuickStop = 0x0002;
inline constexpr std::uint16_t kFaultReset = 0x0080;
}  // namespace controlword

enum class Command : std::uint8_t {
  kShutdown,
  kSwitchOn,           // also disable operation when in Operation Enabled
  kSwitchOnAndEnable,  // enable operation
  kDisableVoltage,
  kQuickStop,
  kFaultReset,  // bit 7 rising edge
  kNone,        // bit 7 held or a reserved pattern: no transition
};
// `previous` is the controlword before this one, for the fault reset edge.
Command decode_controlword(std::uint16_t controlword, std::uint16_t previous);

// The device's next state after `command` (transitions 2..12, 15, 16 of CiA 402 figure 11;
// 0 and 1 are the device's own start-up, 13/14 its fault reaction). Stays put for a command
// the state does not accept.
State next_state(State current, Command command);

// What the master wants of a drive.
enum class Goal : std::uint8_t {
  kOperationEnabled,  // following the target velocity
  kSwitchedOn,        // power stage on, no torque demand (the line's normal stop)
  kQuickStop,         // fastest controlled stop (line fault)
};

// Next controlword to step a drive in `state` towards `goal`, one transition per call
// (statusword confirms each step). In Fault, `reset_fault` asks for a fault reset: the
// master sends 0x0000 then 0x0080 on alternate calls (the reset acts on the edge), with
// `reset_phase` toggled by the caller.
std::uint16_t master_controlword(State state, Goal goal, bool reset_fault, bool reset_phase);

}  // namespace fl::drivers::cia402
