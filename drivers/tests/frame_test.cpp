// Wire encodings: little-endian packing, PDO layouts and sizes, NMT, SYNC, heartbeat, EMCY
// and SDO frames, checked byte by byte against CiA 301.
#include <gtest/gtest.h>

#include <array>
#include <cstdint>

#include "fl/drivers/can_frame.hpp"
#include "fl/drivers/canopen.hpp"
#include "fl/drivers/socketcan.hpp"

namespace fl::drivers {
namespace {

using namespace canopen;

TEST(CanFrame, LittleEndianPackingPutsTheLowByteFirst) {
  std::array<std::uint8_t, 8> data{};
  put_le(data, 1, 4, 0x12345678U);
  // CiA 301 7.1.2: the least significant byte is transmitted first.
  EXPECT_EQ(data[0], 0x00);
  EXPECT_EQ(data[1], 0x78);
  EXPECT_EQ(data[2], 0x56);
  EXPECT_EQ(data[3], 0x34);
  EXPECT_EQ(data[4], 0x12);
  EXPECT_EQ(get_le(data, 1, 4), 0x12345678U);
  EXPECT_EQ(get_le(data, 1, 2), 0x5678U);
}

TEST(CanFrame, PackingNeverWritesPastEightBytes) {
  std::array<std::uint8_t, 8> data{};
  put_le(data, 6, 4, 0xAABBCCDDU);  // two bytes fit, two would overflow: dropped
  EXPECT_EQ(data[6], 0xDD);
  EXPECT_EQ(data[7], 0xCC);
  EXPECT_EQ(get_le(data, 6, 4), 0xCCDDU);
}

TEST(CanFrame, SignExtensionOfTwosComplement) {
  EXPECT_EQ(sign_extend(0xFFFFU, 16), -1);
  EXPECT_EQ(sign_extend(0x8000U, 16), -32768);
  EXPECT_EQ(sign_extend(0x7FFFU, 16), 32767);
  EXPECT_EQ(sign_extend(0xFFFFFFFFU, 32), -1);
  EXPECT_EQ(sign_extend(0x80U, 8), -128);
  EXPECT_EQ(to_wire(-2), 0xFFFFFFFEU);
}

TEST(Pdo, DriveRpdo1IsControlwordThenTargetVelocityInSixBytes) {
  // 16-bit controlword + 32-bit target velocity = 6 bytes.
  EXPECT_EQ(layout::kDriveRpdo1.bytes(), 6U);
  const std::array<std::uint32_t, 2> values{0x000F, to_wire(-5000)};
  const CanFrame frame = pack_pdo(0x201, layout::kDriveRpdo1, values);
  EXPECT_EQ(frame.id, 0x201U);
  ASSERT_EQ(frame.dlc, 6);
  const std::array<std::uint8_t, 6> expected{0x0F, 0x00, 0x78,
                                             0xEC, 0xFF, 0xFF};  // -5000 = 0xFFFFEC78
  for (std::size_t i = 0; i < expected.size(); ++i) {
    EXPECT_EQ(frame.data[i], expected[i]) << "byte " << i;
  }
  std::array<std::uint32_t, 2> back{};
  ASSERT_TRUE(unpack_pdo(frame, layout::kDriveRpdo1, back));
  EXPECT_EQ(back[0], 0x000FU);
  EXPECT_EQ(sign_extend(back[1], 32), -5000);
}

TEST(Pdo, LayoutSizesFitOneFrame) {
  EXPECT_EQ(layout::kDriveRpdo2.bytes(), 8U);  // two 32-bit ramps
  EXPECT_EQ(layout::kDriveTpdo1.bytes(), 6U);  // statusword + position
  EXPECT_EQ(layout::kDriveTpdo2.bytes(), 4U);  // velocity actual
  EXPECT_EQ(layout::kIoTpdo1.bytes(), 7U);     // 8 DI + 3 x 16-bit AI
  EXPECT_EQ(layout::kIoRpdo1.bytes(), 7U);
  for (const PdoMapping* mapping :
       {&layout::kDriveRpdo1, &layout::kDriveRpdo2, &layout::kDriveTpdo1, &layout::kDriveTpdo2,
        &layout::kIoTpdo1, &layout::kIoRpdo1}) {
    EXPECT_TRUE(mapping->valid());
  }
}

TEST(Pdo, MappingValueIsIndexSubindexBits) {
  // CiA 301 7.5.2.36: 0x60FF sub 0, 32 bits -> 0x60FF0020.
  EXPECT_EQ((PdoEntry{0x60FF, 0, 32}.mapping_value()), 0x60FF0020U);
  const PdoEntry back = PdoEntry::from_mapping_value(0x64010210U);
  EXPECT_EQ(back.index, 0x6401);
  EXPECT_EQ(back.subindex, 2);
  EXPECT_EQ(back.bits, 16);
}

TEST(Pdo, WrongLengthIsRefusedAndLeavesValuesAlone) {
  CanFrame frame = make_frame(0x181, 5);  // one byte short of statusword + position
  std::array<std::uint32_t, 2> values{7, 7};
  EXPECT_FALSE(unpack_pdo(frame, layout::kDriveTpdo1, values));
  frame.dlc = 7;  // one byte long: a mapping mismatch as well
  EXPECT_FALSE(unpack_pdo(frame, layout::kDriveTpdo1, values));
  EXPECT_EQ(values[0], 7U);
  EXPECT_EQ(values[1], 7U);
}

TEST(Pdo, InvalidMappingsAreDetected) {
  PdoMapping too_long{{{{0x6000, 1, 32}, {0x6000, 2, 32}, {0x6000, 3, 8}}}, 3};  // 72 bits
  EXPECT_FALSE(too_long.valid());
  PdoMapping odd_size{{{{0x6000, 1, 12}}}, 1};  // only whole bytes here
  EXPECT_FALSE(odd_size.valid());
}

TEST(Nmt, CommandFramesAreTwoBytesOnCobIdZero) {
  const CanFrame start = make_nmt(NmtCommand::kStart, 5);
  EXPECT_EQ(start.id, 0x000U);
  EXPECT_EQ(start.dlc, 2);
  EXPECT_EQ(start.data[0], 0x01);
  EXPECT_EQ(start.data[1], 5);
  EXPECT_EQ(make_nmt(NmtCommand::kStop, 0).data[0], 0x02);
  EXPECT_EQ(make_nmt(NmtCommand::kEnterPreOperational, 0).data[0], 0x80);
  EXPECT_EQ(make_nmt(NmtCommand::kResetNode, 0).data[0], 0x81);
  EXPECT_EQ(make_nmt(NmtCommand::kResetCommunication, 0).data[0], 0x82);
  EXPECT_FALSE(decode_nmt_command(0x03).has_value());
}

TEST(Nmt, SyncIsAnEmptyFrameOn0x80) {
  const CanFrame sync = make_sync();
  EXPECT_EQ(sync.id, 0x080U);
  EXPECT_EQ(sync.dlc, 0);
}

TEST(Heartbeat, StatesDecodeAndGarbageIsRefused) {
  EXPECT_EQ(make_heartbeat(7, NmtState::kOperational).id, 0x707U);
  EXPECT_EQ(decode_heartbeat(make_heartbeat(7, NmtState::kOperational)), NmtState::kOperational);
  EXPECT_EQ(decode_heartbeat(make_heartbeat(7, NmtState::kBootUp)), NmtState::kBootUp);
  CanFrame toggled = make_heartbeat(7, NmtState::kPreOperational);
  toggled.data[0] |= 0x80;  // node guarding toggle bit: ignored
  EXPECT_EQ(decode_heartbeat(toggled), NmtState::kPreOperational);
  CanFrame undefined = make_heartbeat(7, NmtState::kOperational);
  undefined.data[0] = 0x06;  // no such NMT state
  EXPECT_FALSE(decode_heartbeat(undefined).has_value());
  CanFrame long_frame = make_heartbeat(7, NmtState::kOperational);
  long_frame.dlc = 2;
  EXPECT_FALSE(decode_heartbeat(long_frame).has_value());
}

TEST(Emcy, DecodesCodeRegisterAndManufacturerBytes) {
  CanFrame frame = make_frame(0x083, 8);
  frame.data = {0x10, 0x23, 0x03, 0xAA, 0xBB, 0xCC, 0xDD, 0xEE};
  const auto emcy = decode_emcy(frame);
  ASSERT_TRUE(emcy.has_value());
  EXPECT_EQ(emcy->error_code, 0x2310);  // little-endian: 0x10 0x23
  EXPECT_EQ(emcy->error_register, 0x03);
  EXPECT_EQ(emcy->manufacturer[0], 0xAA);
  EXPECT_EQ(emcy->manufacturer[4], 0xEE);
  EXPECT_STREQ(describe_emcy_code(0x2310), "continuous over current");
  EXPECT_STREQ(describe_emcy_code(0x4321), "temperature");  // class from the high nibble
  EXPECT_STREQ(describe_emcy_code(0x0000), "error reset or no error");
  frame.dlc = 6;  // truncated EMCY
  EXPECT_FALSE(decode_emcy(frame).has_value());
}

TEST(Sdo, ExpeditedDownloadCommandBytesEncodeTheSize) {
  // CiA 301 7.2.4.3.3: 0x2F 1 byte, 0x2B 2 bytes, 0x27 3 bytes, 0x23 4 bytes.
  EXPECT_EQ(make_sdo_download(1, {0x6060, 0}, 3, 1).data[0], 0x2F);
  EXPECT_EQ(make_sdo_download(1, {0x1017, 0}, 50, 2).data[0], 0x2B);
  EXPECT_EQ(make_sdo_download(1, {0x2000, 0}, 0, 3).data[0], 0x27);
  const CanFrame frame = make_sdo_download(1, {0x1400, 1}, 0x80000201U, 4);
  EXPECT_EQ(frame.id, 0x601U);
  EXPECT_EQ(frame.dlc, 8);
  EXPECT_EQ(frame.data[0], 0x23);
  EXPECT_EQ(frame.data[1], 0x00);  // index low byte
  EXPECT_EQ(frame.data[2], 0x14);
  EXPECT_EQ(frame.data[3], 0x01);
  EXPECT_EQ(get_le(frame.data, 4, 4), 0x80000201U);
}

TEST(Sdo, ResponsesDecode) {
  const SdoResponse upload =
      decode_sdo_response(make_sdo_upload_expedited_response(3, {0x6061, 0}, 3, 1));
  EXPECT_EQ(upload.kind, SdoResponseKind::kUploadExpedited);
  EXPECT_EQ(upload.size_bytes, 1);
  EXPECT_EQ(upload.value, 3U);
  const SdoResponse abort =
      decode_sdo_response(make_sdo_abort(0x583, {0x2000, 0}, sdo_abort::kNoObject));
  EXPECT_EQ(abort.kind, SdoResponseKind::kAbort);
  EXPECT_EQ(abort.value, 0x06020000U);
  EXPECT_EQ(abort.address.index, 0x2000);
  EXPECT_STREQ(describe_sdo_abort(abort.value), "object does not exist in the object dictionary");
  EXPECT_STREQ(describe_sdo_abort(0x05030000), "toggle bit not alternated");
  EXPECT_STREQ(describe_sdo_abort(0x12345678), "unknown abort code");
}

TEST(Sdo, TruncatedOrUnknownResponsesAreInvalid) {
  CanFrame truncated = make_sdo_download_response(3, {0x1017, 0});
  truncated.dlc = 4;  // SDO frames are always 8 bytes
  EXPECT_EQ(decode_sdo_response(truncated).kind, SdoResponseKind::kInvalid);
  CanFrame unknown = make_sdo_download_response(3, {0x1017, 0});
  unknown.data[0] = 0xE0;  // scs 7: not defined
  EXPECT_EQ(decode_sdo_response(unknown).kind, SdoResponseKind::kInvalid);
}

TEST(Sdo, SegmentCarriesToggleLengthAndLastFlag) {
  const std::array<std::uint8_t, 3> bytes{'a', 'b', 'c'};
  const SdoResponse segment = decode_sdo_response(make_sdo_upload_segment(3, true, bytes, true));
  EXPECT_EQ(segment.kind, SdoResponseKind::kUploadSegment);
  EXPECT_TRUE(segment.toggle);
  EXPECT_TRUE(segment.last_segment);
  EXPECT_EQ(segment.segment_bytes, 3);
  EXPECT_EQ(segment.segment[2], 'c');
}

TEST(BusLoad, WorstCaseFrameLengthsIncludeStuffBits) {
  // 8 data bytes: 47 + 64 fixed bits and at most 24 stuff bits = 135 (Tindell/Davis).
  EXPECT_EQ(worst_case_frame_bits(8), 135U);
  EXPECT_EQ(worst_case_frame_bits(0), 55U);  // SYNC: 47 + 8 stuff bits
}

CanFrame numbered_frame(std::uint32_t id, std::uint8_t first_byte) {
  CanFrame frame = make_frame(id, 1);
  frame.data[0] = first_byte;
  return frame;
}

TEST(SendConfirmations, EachEchoMatchesItsOwnSendEvenOutOfOrder) {
  SendConfirmationQueue queue;
  CanBusCounters counters;
  queue.record_send(numbered_frame(0x205, 1), 100, counters);
  queue.record_send(numbered_frame(0x080, 0), 200, counters);
  queue.record_send(numbered_frame(0x205, 2), 300, counters);
  // A controller with several TX buffers sends by priority: SYNC (0x080) wins arbitration.
  EXPECT_TRUE(queue.confirm(numbered_frame(0x080, 0), 250, counters));
  // Same id twice: the data tells them apart.
  EXPECT_TRUE(queue.confirm(numbered_frame(0x205, 2), 350, counters));
  EXPECT_TRUE(queue.confirm(numbered_frame(0x205, 1), 400, counters));
  // Nothing was sent with these bytes: no record, no confirmation.
  EXPECT_FALSE(queue.confirm(numbered_frame(0x205, 3), 450, counters));

  std::array<CanSendConfirmation, 8> taken{};
  ASSERT_EQ(queue.take(taken), 3U);
  EXPECT_EQ(taken[0].id, 0x080U);
  EXPECT_EQ(taken[0].queued_ns, 200);
  EXPECT_EQ(taken[0].sent_ns, 250);
  EXPECT_EQ(taken[1].queued_ns, 300);  // the second 0x205, by its data
  EXPECT_EQ(taken[2].queued_ns, 100);
  EXPECT_EQ(counters.sends_confirmed, 3U);
  EXPECT_EQ(queue.take(taken), 0U);
}

TEST(SendConfirmations, LostEchoesAndAnIdleConsumerAreCountedNotGrown) {
  SendConfirmationQueue queue;
  CanBusCounters counters;
  constexpr std::size_t kCapacity = SendConfirmationQueue::kCapacity;
  // One more send than there are records: the oldest is given up as unconfirmed.
  for (std::size_t i = 0; i <= kCapacity; ++i) {
    queue.record_send(numbered_frame(0x300, static_cast<std::uint8_t>(i % 200)),
                      static_cast<std::int64_t>(i), counters);
  }
  EXPECT_EQ(counters.sends_unconfirmed, 1U);
  // Frame 0 was evicted, so its echo finds the next frame with byte 0: number 200.
  ASSERT_TRUE(queue.confirm(numbered_frame(0x300, 0), 1000, counters));
  std::array<CanSendConfirmation, 1> first{};
  ASSERT_EQ(queue.take(first), 1U);
  EXPECT_EQ(first[0].queued_ns, 200);

  // Nobody takes confirmations: past the capacity they are dropped and counted.
  SendConfirmationQueue idle;
  CanBusCounters idle_counters;
  for (std::size_t i = 0; i < kCapacity + 5; ++i) {
    const CanFrame frame = numbered_frame(0x301, 7);
    idle.record_send(frame, 0, idle_counters);
    idle.confirm(frame, 1, idle_counters);
  }
  EXPECT_EQ(idle_counters.sends_confirmed, kCapacity + 5);
  EXPECT_EQ(idle_counters.confirmations_dropped, 5U);
}

TEST(SocketCanErrors, ErrorFramesDriveTheErrorState) {
  // Class bits and data[1] values from linux/can/error.h.
  constexpr std::uint32_t kController = 0x004;
  constexpr std::uint32_t kBusOff = 0x040;
  constexpr std::uint32_t kRestarted = 0x100;
  std::array<std::uint8_t, 8> data{};
  data[1] = 0x08;  // TX warning
  EXPECT_EQ(SocketCanBus::next_error_state(CanErrorState::kErrorActive, kController, data),
            CanErrorState::kErrorWarning);
  data[1] = 0x20;  // TX passive
  EXPECT_EQ(SocketCanBus::next_error_state(CanErrorState::kErrorWarning, kController, data),
            CanErrorState::kErrorPassive);
  data = {};
  EXPECT_EQ(SocketCanBus::next_error_state(CanErrorState::kErrorPassive, kBusOff, data),
            CanErrorState::kBusOff);
  EXPECT_EQ(SocketCanBus::next_error_state(CanErrorState::kBusOff, kRestarted, data),
            CanErrorState::kErrorActive);
  data[1] = 0x40;  // back to error active
  EXPECT_EQ(SocketCanBus::next_error_state(CanErrorState::kErrorPassive, kController, data),
            CanErrorState::kErrorActive);
}

}  // namespace
}  // namespace fl::drivers
