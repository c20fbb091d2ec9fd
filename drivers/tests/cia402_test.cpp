// CiA 402 state machine: statusword decoding (table 30), controlword commands (table 28),
// the device transitions of figure 11 and the master's stepping towards its goal.
#include <gtest/gtest.h>

#include "fl/drivers/canopen_cia402.hpp"

namespace fl::drivers::cia402 {
namespace {

TEST(Cia402Statusword, DecodesEveryStateOfTable30) {
  EXPECT_EQ(decode_statusword(0x0000), State::kNotReadyToSwitchOn);
  EXPECT_EQ(decode_statusword(0x0040), State::kSwitchOnDisabled);
  EXPECT_EQ(decode_statusword(0x0021), State::kReadyToSwitchOn);
  EXPECT_EQ(decode_statusword(0x0023), State::kSwitchedOn);
  EXPECT_EQ(decode_statusword(0x0027), State::kOperationEnabled);
  EXPECT_EQ(decode_statusword(0x0007), State::kQuickStopActive);
  EXPECT_EQ(decode_statusword(0x000F), State::kFaultReactionActive);
  EXPECT_EQ(decode_statusword(0x0008), State::kFault);
  // Bits outside the pattern (4 voltage enabled, 9 remote, 10 target reached) don't matter.
  EXPECT_EQ(decode_statusword(0x0637), State::kOperationEnabled);
  EXPECT_EQ(decode_statusword(0x0228), State::kFault);  // fault ignores bit 5
  EXPECT_EQ(decode_statusword(0x0001), State::kUnknown);
}

TEST(Cia402Statusword, EmulatedBitsDecodeBackToTheirState) {
  for (State state : {State::kNotReadyToSwitchOn, State::kSwitchOnDisabled, State::kReadyToSwitchOn,
                      State::kSwitchedOn, State::kOperationEnabled, State::kQuickStopActive,
                      State::kFaultReactionActive, State::kFault}) {
    EXPECT_EQ(decode_statusword(statusword_bits(state)), state) << to_string(state);
  }
}

TEST(Cia402Controlword, CommandsOfTable28) {
  EXPECT_EQ(decode_controlword(0x0006, 0), Command::kShutdown);
  EXPECT_EQ(decode_controlword(0x0007, 0), Command::kSwitchOn);
  EXPECT_EQ(decode_controlword(0x000F, 0), Command::kSwitchOnAndEnable);
  EXPECT_EQ(decode_controlword(0x0000, 0), Command::kDisableVoltage);
  EXPECT_EQ(decode_controlword(0x0004, 0), Command::kDisableVoltage);  // bit 1 clear
  EXPECT_EQ(decode_controlword(0x0002, 0), Command::kQuickStop);
  EXPECT_EQ(decode_controlword(0x000B, 0), Command::kQuickStop);  // bit 2 clear, bit 1 set
  EXPECT_EQ(decode_controlword(0x0080, 0x0000), Command::kFaultReset);
  EXPECT_EQ(decode_controlword(0x0080, 0x0080), Command::kNone);  // no edge
}

struct Transition {
  State from;
  Command command;
  State to;
  const char* name;
};

TEST(Cia402Transitions, FollowFigure11) {
  const Transition table[] = {
      {State::kSwitchOnDisabled, Command::kShutdown, State::kReadyToSwitchOn, "2"},
      {State::kReadyToSwitchOn, Command::kSwitchOn, State::kSwitchedOn, "3"},
      {State::kReadyToSwitchOn, Command::kSwitchOnAndEnable, State::kOperationEnabled, "3+4"},
      {State::kSwitchedOn, Command::kSwitchOnAndEnable, State::kOperationEnabled, "4"},
      {State::kOperationEnabled, Command::kSwitchOn, State::kSwitchedOn, "5"},
      {State::kSwitchedOn, Command::kShutdown, State::kReadyToSwitchOn, "6"},
      {State::kReadyToSwitchOn, Command::kDisableVoltage, State::kSwitchOnDisabled, "7"},
      {State::kReadyToSwitchOn, Command::kQuickStop, State::kSwitchOnDisabled, "7 (quick stop)"},
      {State::kOperationEnabled, Command::kShutdown, State::kReadyToSwitchOn, "8"},
      {State::kOperationEnabled, Command::kDisableVoltage, State::kSwitchOnDisabled, "9"},
      {State::kSwitchedOn, Command::kDisableVoltage, State::kSwitchOnDisabled, "10"},
      {State::kSwitchedOn, Command::kQuickStop, State::kSwitchOnDisabled, "10 (quick stop)"},
      {State::kOperationEnabled, Command::kQuickStop, State::kQuickStopActive, "11"},
      {State::kQuickStopActive, Command::kDisableVoltage, State::kSwitchOnDisabled, "12"},
      {State::kFault, Command::kFaultReset, State::kSwitchOnDisabled, "15"},
      {State::kQuickStopActive, Command::kSwitchOnAndEnable, State::kOperationEnabled, "16"},
      // Commands a state does not accept leave it alone.
      {State::kSwitchOnDisabled, Command::kSwitchOnAndEnable, State::kSwitchOnDisabled, "-"},
      {State::kFault, Command::kSwitchOnAndEnable, State::kFault, "-"},
      {State::kFaultReactionActive, Command::kFaultReset, State::kFaultReactionActive, "-"},
  };
  for (const Transition& t : table) {
    EXPECT_EQ(next_state(t.from, t.command), t.to) << "transition " << t.name;
  }
}

// The master's controlword sequence, fed back through the device table, reaches the goal
// in at most three steps from Switch On Disabled (transitions 2, 3, 4).
TEST(Cia402Master, StepsFromSwitchOnDisabledToOperationEnabledInThreeScans) {
  State state = State::kSwitchOnDisabled;
  std::uint16_t previous = 0;
  int steps = 0;
  while (state != State::kOperationEnabled && steps < 10) {
    const std::uint16_t word = master_controlword(state, Goal::kOperationEnabled, false, false);
    state = next_state(state, decode_controlword(word, previous));
    previous = word;
    ++steps;
  }
  EXPECT_EQ(state, State::kOperationEnabled);
  EXPECT_EQ(steps, 3);
}

TEST(Cia402Master, DisablesToSwitchedOnAndQuickStopsOnLineFault) {
  EXPECT_EQ(master_controlword(State::kOperationEnabled, Goal::kSwitchedOn, false, false),
            controlword::kDisableOperation);
  EXPECT_EQ(master_controlword(State::kOperationEnabled, Goal::kQuickStop, false, false),
            controlword::kQuickStop);
  EXPECT_EQ(master_controlword(State::kQuickStopActive, Goal::kQuickStop, false, false),
            controlword::kQuickStop);
}

TEST(Cia402Master, FaultResetIsAnEdgeOnlyWhenAsked) {
  EXPECT_EQ(master_controlword(State::kFault, Goal::kOperationEnabled, false, true),
            controlword::kDisableVoltage);
  // Alternating phases make 0x0000 -> 0x0080: a rising edge of bit 7.
  const std::uint16_t low = master_controlword(State::kFault, Goal::kOperationEnabled, true, false);
  const std::uint16_t high = master_controlword(State::kFault, Goal::kOperationEnabled, true, true);
  EXPECT_EQ(decode_controlword(high, low), Command::kFaultReset);
}

}  // namespace
}  // namespace fl::drivers::cia402
