// Indexed reads: time ranges and topics answered from the chunk and message indexes, and
// the summary's statistics and offsets.

#include <gtest/gtest.h>

#include <algorithm>

#include "codec.hpp"
#include "mcap_test_support.hpp"

namespace fl::mcap::test {
namespace {

std::vector<Message> expected_in(const std::vector<Message>& written, Timestamp start,
                                 Timestamp end, std::uint16_t only_channel = 0) {
  std::vector<Message> expected;
  for (const Message& message : written) {
    if (message.log_time < start || message.log_time > end) continue;
    if (only_channel != 0 && message.channel_id != only_channel) continue;
    expected.push_back(message);
  }
  std::stable_sort(expected.begin(), expected.end(),
                   [](const Message& a, const Message& b) { return a.log_time < b.log_time; });
  return expected;
}

void expect_same(const std::vector<Message>& read, const std::vector<Message>& expected) {
  ASSERT_EQ(read.size(), expected.size());
  for (std::size_t i = 0; i < read.size(); ++i) {
    ASSERT_TRUE(same_message(read[i], expected[i])) << "message " << i;
  }
}

TEST(IndexedRead, TimeRangeReadsOnlyTheChunksThatOverlapIt) {
  const WrittenFile file = write_recording({});
  const Reader reader = open_bytes(file.bytes);
  const std::size_t chunk_count = reader.summary().chunk_indexes.size();
  // Frames 100..150 inclusive: a sixth of the recording, well inside it.
  const Timestamp start = frame_time(100);
  const Timestamp end = frame_time(150);
  const std::vector<Message> read = reader.read_messages(time_filter(start, end));
  expect_same(read, expected_in(file.messages, start, end));
  EXPECT_EQ(read.size(), 51U);  // both ends inclusive
  // A sixth of the time needs about a sixth of the chunks, plus one at each edge.
  EXPECT_LE(reader.chunks_read_last_call(), chunk_count / 6 + 2);
  EXPECT_GE(reader.chunks_read_last_call(), 1U);
}

TEST(IndexedRead, TopicFilterSkipsChunksWithoutThatTopic) {
  const WrittenFile file = write_recording({});
  const Reader reader = open_bytes(file.bytes);
  const std::vector<Message> events = reader.read_messages(topic_filter({kTopics[2]}));
  expect_same(events, expected_in(file.messages, 0, ~Timestamp{0}, 3));
  EXPECT_EQ(events.size(), 100U);

  const std::vector<Message> left_late =
      reader.read_messages(time_filter(frame_time(200), ~Timestamp{0}, {kTopics[0]}));
  expect_same(left_late, expected_in(file.messages, frame_time(200), ~Timestamp{0}, 1));

  EXPECT_TRUE(reader.read_messages(topic_filter({"/no/such/topic"})).empty());
  // No chunk holds the unknown topic, so none is decompressed.
  EXPECT_EQ(reader.chunks_read_last_call(), 0U);
  EXPECT_TRUE(
      reader.read_messages(time_filter(frame_time(400), ~Timestamp{0})).empty());  // after the end
}

TEST(IndexedRead, OverlappingChunksStillComeOutInLogTimeOrder) {
  RecordingShape shuffled;
  shuffled.shuffle_times = true;
  const WrittenFile file = write_recording({}, shuffled);
  const Reader reader = open_bytes(file.bytes);
  const std::vector<Message> read = reader.read_messages();
  expect_same(read, expected_in(file.messages, 0, ~Timestamp{0}));
  const Timestamp start = frame_time(120);
  const Timestamp end = frame_time(180);
  expect_same(reader.read_messages(time_filter(start, end)),
              expected_in(file.messages, start, end));
}

TEST(IndexedRead, ForEachMessageNamesTheChannel) {
  const WrittenFile file = write_recording({}, shape(9, 16 * 1024));
  const Reader reader = open_bytes(file.bytes);
  int count = 0;
  reader.for_each_message({}, [&](const Message& message, const Channel& channel) {
    EXPECT_EQ(channel.id, message.channel_id);
    EXPECT_EQ(channel.topic, kTopics[count % 3]);
    ++count;
  });
  EXPECT_EQ(count, 9);
}

TEST(Summary, StatisticsCountWhatWasWritten) {
  const WrittenFile file = write_recording({});
  const Reader reader = open_bytes(file.bytes);
  ASSERT_TRUE(reader.summary().statistics.has_value());
  const Statistics& statistics = *reader.summary().statistics;
  EXPECT_EQ(statistics.message_count, 300U);
  EXPECT_EQ(statistics.schema_count, 2U);
  EXPECT_EQ(statistics.channel_count, 3U);
  EXPECT_EQ(statistics.attachment_count, 1U);
  EXPECT_EQ(statistics.metadata_count, 1U);
  EXPECT_EQ(statistics.chunk_count, reader.summary().chunk_indexes.size());
  EXPECT_EQ(statistics.message_start_time, frame_time(0));
  EXPECT_EQ(statistics.message_end_time, frame_time(299));
  const std::map<std::uint16_t, std::uint64_t> per_channel = {{1, 100}, {2, 100}, {3, 100}};
  EXPECT_EQ(statistics.channel_message_counts, per_channel);
  EXPECT_EQ(statistics.message_count, file.statistics.message_count);
}

TEST(Summary, OffsetsPointAtEachGroupOfRecords) {
  const WrittenFile file = write_recording({});
  const Reader reader = open_bytes(file.bytes);
  const std::vector<SummaryOffset>& offsets = reader.summary().summary_offsets;
  // Schemas, channels, statistics, chunk indexes, attachment and metadata indexes.
  ASSERT_EQ(offsets.size(), 6U);
  std::uint64_t expected_start = reader.footer().summary_start;
  for (const SummaryOffset& offset : offsets) {
    EXPECT_EQ(offset.group_start, expected_start);  // groups are contiguous, in order
    std::uint64_t position = offset.group_start;
    while (position < offset.group_start + offset.group_length) {
      ASSERT_EQ(file.bytes[position], static_cast<std::uint8_t>(offset.group_opcode));
      detail::Cursor length(ByteView(file.bytes).subspan(position + 1, 8), position + 1, "test");
      position += kRecordPrefixSize + length.u64();
    }
    EXPECT_EQ(position, offset.group_start + offset.group_length);
    expected_start = position;
  }
  EXPECT_EQ(expected_start, reader.footer().summary_offset_start);
}

TEST(Summary, ChunkIndexesDescribeTheirChunks) {
  const WrittenFile file = write_recording(compressed(Compression::kLz4));
  const Reader reader = open_bytes(file.bytes);
  std::uint64_t messages_in_index_range = 0;
  for (const ChunkIndex& index : reader.summary().chunk_indexes) {
    EXPECT_EQ(file.bytes[index.chunk_start_offset], static_cast<std::uint8_t>(Opcode::kChunk));
    EXPECT_LE(index.message_start_time, index.message_end_time);
    EXPECT_LT(index.compressed_size, index.uncompressed_size);  // the pattern compresses
    EXPECT_FALSE(index.message_index_offsets.empty());
    for (const auto& [channel, offset] : index.message_index_offsets) {
      EXPECT_EQ(file.bytes[offset], static_cast<std::uint8_t>(Opcode::kMessageIndex));
      EXPECT_GE(offset, index.chunk_start_offset + index.chunk_length);
    }
    for (const Message& message : file.messages) {
      if (message.log_time >= index.message_start_time &&
          message.log_time <= index.message_end_time) {
        ++messages_in_index_range;
      }
    }
  }
  EXPECT_EQ(messages_in_index_range, 300U);  // in-order times: chunk ranges do not overlap
}

}  // namespace
}  // namespace fl::mcap::test
