#pragma once
// Shared fixtures for the MCAP tests: a deterministic camera-like recording written into
// memory, and helpers to read it back.

#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

#include "fl/mcap/reader.hpp"
#include "fl/mcap/writer.hpp"

namespace fl::mcap::test {

struct WrittenFile {
  Bytes bytes;
  std::vector<Message> messages;  // in write order
  Statistics statistics;          // as the writer counted
};

struct RecordingShape {
  int message_count = 300;  // 100 per channel: enough for many chunks, quick to check
  // 16 KiB chunks against 1-10 KB frames: a few frames per chunk, so dozens of chunks.
  std::uint64_t chunk_size = std::uint64_t{16} * 1024;
  bool with_attachment_and_metadata = true;
  bool shuffle_times = false;  // log times out of write order, so chunks overlap in time
  // Camera frame sizes: frame_min_bytes plus up to frame_spread_bytes. 1000..9999 bytes by
  // default (a compressed 640x480 image is in that range).
  std::size_t frame_min_bytes = 1000;
  std::size_t frame_spread_bytes = 9000;
};

// Camera frames on two channels and small events on a third; content depends only on
// the message index, so any two writes of the same shape are byte-identical.
WrittenFile write_recording(WriterOptions options, const RecordingShape& shape = {});

Bytes frame_payload(int index, std::size_t size);
Timestamp frame_time(int index);
inline constexpr const char* kTopics[] = {"/camera/left/image", "/camera/right/image",
                                          "/line/events"};

// Builders instead of designated initializers (GCC 12 warns about the fields left out).
MessageFilter time_filter(Timestamp start, Timestamp end, std::vector<std::string> topics = {});
MessageFilter topic_filter(std::vector<std::string> topics);
WriterOptions compressed(Compression compression);
RecordingShape shape(int message_count, std::uint64_t chunk_size);
ReaderOptions without_crc_checks();
// Test names for the per-compression suites: none, zstd, lz4.
std::string compression_test_name(const ::testing::TestParamInfo<Compression>& param_info);

// Byte offsets worth damaging in a well-formed file: the first 64 bytes and the last 8 of
// every top-level record (opcodes, lengths, times, sizes, CRCs, names) and every 17th byte
// in between (payloads). Keeps the every-offset tests linear instead of quadratic in size.
std::vector<std::size_t> probe_offsets(const Bytes& bytes);

Reader open_bytes(const Bytes& bytes, ReaderOptions options = {});
bool same_message(const Message& a, const Message& b);
// True when `prefix` equals the first prefix.size() entries of `all`.
bool is_prefix(const std::vector<Message>& prefix, const std::vector<Message>& all);

}  // namespace fl::mcap::test
