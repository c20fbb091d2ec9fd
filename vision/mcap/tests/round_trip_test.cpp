// Round trips: what the writer writes, the reader returns unchanged, for each compression.

#include <gtest/gtest.h>

#include <sstream>
#include <string_view>

#include "mcap_test_support.hpp"

namespace fl::mcap::test {
namespace {

TEST(Crc32, MatchesTheStandardCheckValue) {
  // CRC-32/ISO-HDLC of "123456789" is 0xCBF43926 (the catalogue's check value).
  const std::string_view text = "123456789";
  const ByteView bytes(reinterpret_cast<const std::uint8_t*>(text.data()), text.size());
  EXPECT_EQ(crc32(bytes), 0xCBF43926U);
  // Continuing over two pieces gives the same result as one pass.
  EXPECT_EQ(crc32(bytes.subspan(4), crc32(bytes.first(4))), 0xCBF43926U);
}

class RoundTrip : public ::testing::TestWithParam<Compression> {};

TEST_P(RoundTrip, SchemasChannelsAndMessagesComeBackUnchanged) {
  WriterOptions options;
  options.compression = GetParam();
  options.profile = "ros2";
  const WrittenFile file = write_recording(options);
  const Reader reader = open_bytes(file.bytes);

  EXPECT_EQ(reader.header().profile, "ros2");
  EXPECT_EQ(reader.header().library, "fl_mcap");
  ASSERT_TRUE(reader.indexed());
  const Summary& summary = reader.summary();
  ASSERT_EQ(summary.schemas.size(), 2U);  // image and event schemas
  EXPECT_EQ(summary.schemas.at(1).name, "sensor_msgs/msg/Image");
  EXPECT_EQ(summary.schemas.at(1).encoding, "ros2msg");
  EXPECT_EQ(summary.schemas.at(2).encoding, "jsonschema");
  ASSERT_EQ(summary.channels.size(), 3U);  // left, right camera and events
  EXPECT_EQ(summary.channels.at(1).topic, kTopics[0]);
  EXPECT_EQ(summary.channels.at(1).message_encoding, "cdr");
  EXPECT_EQ(summary.channels.at(2).metadata.at("camera"), "right");
  EXPECT_EQ(summary.channels.at(3).schema_id, 2);
  // 300 messages of ~5.5 KB on average in 16 KiB chunks: far more than one chunk.
  EXPECT_GT(summary.chunk_indexes.size(), 10U);
  for (const ChunkIndex& index : summary.chunk_indexes) {
    EXPECT_EQ(index.compression, compression_name(GetParam()));
  }

  const std::vector<Message> read = reader.read_messages();
  ASSERT_EQ(read.size(), file.messages.size());
  for (std::size_t i = 0; i < read.size(); ++i) {
    ASSERT_TRUE(same_message(read[i], file.messages[i])) << "message " << i;
  }

  // The front-to-back scan sees the same file the same way.
  const ScanResult scanned = scan(MemorySource(file.bytes));
  EXPECT_TRUE(scanned.complete) << scanned.stop_reason;
  EXPECT_TRUE(scanned.reached_data_end);
  ASSERT_EQ(scanned.messages.size(), file.messages.size());
  EXPECT_TRUE(is_prefix(scanned.messages, file.messages));
  EXPECT_NO_THROW(reader.verify_data_section_crc());
}

TEST_P(RoundTrip, AttachmentsAndMetadataComeBackThroughTheirIndexes) {
  WriterOptions options;
  options.compression = GetParam();
  const WrittenFile file = write_recording(options, shape(30, 16 * 1024));
  const Reader reader = open_bytes(file.bytes);
  ASSERT_EQ(reader.summary().attachment_indexes.size(), 1U);
  const AttachmentIndex& attachment_index = reader.summary().attachment_indexes[0];
  EXPECT_EQ(attachment_index.name, "calibration.yaml");
  const Attachment attachment = reader.read_attachment(attachment_index);
  EXPECT_EQ(attachment.media_type, "application/yaml");
  EXPECT_EQ(std::string(attachment.data.begin(), attachment.data.end()),
            "camera: left\nfx: 1400.5\n");
  EXPECT_EQ(attachment.log_time, frame_time(0));
  EXPECT_EQ(attachment.create_time, frame_time(0) - 1);
  EXPECT_EQ(attachment_index.data_size, attachment.data.size());

  ASSERT_EQ(reader.summary().metadata_indexes.size(), 1U);
  const Metadata metadata = reader.read_metadata(reader.summary().metadata_indexes[0]);
  EXPECT_EQ(metadata.name, "line");
  EXPECT_EQ(metadata.metadata.at("line_id"), "fillet-1");
  EXPECT_EQ(metadata.metadata.at("camera_count"), "2");

  const ScanResult scanned = scan(MemorySource(file.bytes));
  ASSERT_EQ(scanned.attachments.size(), 1U);
  EXPECT_EQ(scanned.attachments[0].data, attachment.data);
  ASSERT_EQ(scanned.metadata.size(), 1U);
  EXPECT_EQ(scanned.metadata[0].metadata, metadata.metadata);
}

INSTANTIATE_TEST_SUITE_P(EachCompression, RoundTrip,
                         ::testing::Values(Compression::kNone, Compression::kZstd,
                                           Compression::kLz4),
                         compression_test_name);

TEST(RoundTrip, CompressionShrinksTheFile) {
  // The payload pattern repeats every 256 bytes, so both compressors must gain a lot.
  WriterOptions options;
  options.compression = Compression::kNone;
  const std::size_t plain = write_recording(options).bytes.size();
  options.compression = Compression::kZstd;
  EXPECT_LT(write_recording(options).bytes.size(), plain / 2);
  options.compression = Compression::kLz4;
  EXPECT_LT(write_recording(options).bytes.size(), plain / 2);
}

TEST(RoundTrip, FileWithoutSummaryIsReadByScanning) {
  WriterOptions options;
  options.write_summary = false;
  const WrittenFile file = write_recording(options);
  const Reader reader = open_bytes(file.bytes);
  EXPECT_FALSE(reader.indexed());
  EXPECT_EQ(reader.footer().summary_start, 0U);
  EXPECT_EQ(reader.summary().channels.size(), 3U);  // learnt by the scan
  const std::vector<Message> read = reader.read_messages(topic_filter({kTopics[2]}));
  ASSERT_EQ(read.size(), 100U);  // every third of 300 messages is an event
  for (const Message& message : read) EXPECT_EQ(message.channel_id, 3);
}

TEST(RoundTrip, UnchunkedMessagesAreReadByScanning) {
  WriterOptions options;
  options.use_chunks = false;
  const WrittenFile file = write_recording(options);
  const Reader reader = open_bytes(file.bytes);
  EXPECT_FALSE(reader.indexed());  // messages outside chunks have no index
  const std::vector<Message> read = reader.read_messages();
  ASSERT_EQ(read.size(), file.messages.size());
  EXPECT_TRUE(is_prefix(read, file.messages));
  ASSERT_TRUE(reader.summary().statistics.has_value());
  EXPECT_EQ(reader.summary().statistics->message_count, 300U);
  EXPECT_EQ(reader.summary().statistics->chunk_count, 0U);
}

TEST(RoundTrip, EmptyRecordingIsValid) {
  RecordingShape empty = shape(0, 16 * 1024);
  empty.with_attachment_and_metadata = false;
  const WrittenFile file = write_recording({}, empty);
  const Reader reader = open_bytes(file.bytes);
  EXPECT_TRUE(reader.read_messages().empty());
  ASSERT_TRUE(reader.summary().statistics.has_value());
  EXPECT_EQ(reader.summary().statistics->message_count, 0U);
  EXPECT_EQ(reader.summary().statistics->message_start_time, 0U);  // spec: zero without messages
  EXPECT_TRUE(scan(MemorySource(file.bytes)).complete);
}

TEST(RoundTrip, WritesAndReadsAFileOnDisk) {
  const std::filesystem::path path =
      std::filesystem::path(::testing::TempDir()) / "fl_mcap_round_trip.mcap";
  {
    Writer writer(path, {});
    const std::uint16_t channel = writer.add_channel(0, "/raw", "application/octet-stream");
    const Bytes data = frame_payload(7, 64);
    writer.write_message({channel, 1, 5, 5, data});
    writer.close();
  }
  const Reader reader = Reader::open(path);
  const std::vector<Message> read = reader.read_messages();
  ASSERT_EQ(read.size(), 1U);
  EXPECT_EQ(read[0].data, frame_payload(7, 64));
  EXPECT_TRUE(scan_file(path).complete);
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace fl::mcap::test
