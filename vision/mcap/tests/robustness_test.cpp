// Malformed input: truncated recordings are recovered up to the damage (every chunk that
// ended before a cut, as power loss leaves them), corrupted bytes give an error or the right
// data, every error names a byte offset, and a full disk is named with the file. Run these under
// ASan (FL_SANITIZE=ON) to show that no input reads out of bounds.

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <sstream>

#include "codec.hpp"
#include "mcap_test_support.hpp"

namespace fl::mcap::test {
namespace {

// A small recording keeps the every-offset loops quick: 60 messages of 100..999-byte frames
// in 2 KiB chunks give about 15 chunks in a file of at most about 25 KB.
RecordingShape small_shape() {
  RecordingShape small = shape(60, 2 * 1024);
  small.frame_min_bytes = 100;
  small.frame_spread_bytes = 900;
  return small;
}

Bytes cut(const Bytes& bytes, std::size_t length) {
  return Bytes(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(length));
}

void write_u64(Bytes& bytes, std::uint64_t at, std::uint64_t value) {
  for (int i = 0; i < 8; ++i) {
    bytes[at + static_cast<std::uint64_t>(i)] = static_cast<std::uint8_t>(value >> (8 * i));
  }
}

std::uint64_t first_offset_of(const Bytes& bytes, Opcode opcode) {
  // Walk the records from the header on; the test files are well formed up to here.
  std::uint64_t position = kMagic.size();
  while (position + kRecordPrefixSize <= bytes.size()) {
    if (bytes[position] == static_cast<std::uint8_t>(opcode)) return position;
    detail::Cursor length(ByteView(bytes).subspan(position + 1, 8), position + 1, "test");
    position += kRecordPrefixSize + length.u64();
  }
  ADD_FAILURE() << "no record with opcode " << static_cast<int>(opcode);
  return 0;
}

class Truncation : public ::testing::TestWithParam<Compression> {};

TEST_P(Truncation, EveryCutRecoversAPrefixAndSaysWhereItStopped) {
  WriterOptions options;
  options.compression = GetParam();
  const WrittenFile file = write_recording(options, small_shape());
  const std::uint64_t data_end = first_offset_of(file.bytes, Opcode::kDataEnd);
  std::size_t previous_count = 0;
  // Every record boundary, the bytes around it, and every 17th byte in between.
  std::vector<std::size_t> lengths = probe_offsets(file.bytes);
  lengths.push_back(file.bytes.size());
  for (const std::size_t length : lengths) {
    const Bytes truncated = cut(file.bytes, length);
    const ScanResult result = scan(MemorySource(truncated));
    ASSERT_TRUE(is_prefix(result.messages, file.messages)) << "cut at " << length;
    ASSERT_GE(result.messages.size(), previous_count) << "cut at " << length;  // monotone
    previous_count = result.messages.size();
    if (length == file.bytes.size()) {
      EXPECT_TRUE(result.complete) << result.stop_reason;
      continue;
    }
    ASSERT_FALSE(result.complete) << "cut at " << length;
    ASSERT_FALSE(result.stop_reason.empty());
    ASSERT_LE(result.stopped_at, length);
    if (length > data_end) {
      ASSERT_EQ(result.messages.size(), file.messages.size()) << "cut at " << length;
    }
    // The indexed reader refuses the damaged file with an offset instead of guessing.
    try {
      (void)open_bytes(truncated);
      ADD_FAILURE() << "a file cut at " << length << " opened";
    } catch (const Error& error) {
      ASSERT_LE(error.offset(), length);
    }
  }
  EXPECT_EQ(previous_count, file.messages.size());
}

INSTANTIATE_TEST_SUITE_P(EachCompression, Truncation,
                         ::testing::Values(Compression::kNone, Compression::kZstd,
                                           Compression::kLz4),
                         compression_test_name);

TEST(Truncation, RecordingInterruptedMidWriteKeepsItsFlushedChunks) {
  // A recorder that dies leaves whatever reached the file: here, the stream before close().
  std::ostringstream stream;
  WriterOptions options;
  options.chunk_size = 4 * 1024;
  Writer writer(stream, options);
  const std::uint16_t channel = writer.add_channel(0, "/camera", "raw");
  for (int i = 0; i < 40; ++i) {
    const Bytes data = frame_payload(i, 1500);
    writer.write_message(
        {channel, static_cast<std::uint32_t>(i), frame_time(i), frame_time(i), data});
  }
  const std::string partial = stream.str();
  const ScanResult result = scan(MemorySource(Bytes(partial.begin(), partial.end())));
  EXPECT_FALSE(result.complete);
  EXPECT_EQ(result.stopped_at, partial.size());  // every record so far was whole
  EXPECT_NE(result.stop_reason.find("truncated"), std::string::npos) << result.stop_reason;
  // 1.5 KB frames close a 4 KiB chunk every 3 frames: 13 chunks (39 frames) are on disk.
  EXPECT_EQ(result.messages.size(), 39U);
  writer.close();
}

// Power loss (or a killed recorder) at any byte: every chunk whose record ended before the
// cut comes back whole, so what is lost is bounded by the chunk the cut went through (plus the
// chunk still open in the writer, which never reached the file).
TEST_P(Truncation, EveryCutKeepsEveryChunkThatEndedBeforeIt) {
  WriterOptions options;
  options.compression = GetParam();
  const WrittenFile file = write_recording(options, small_shape());
  const Reader reader = open_bytes(file.bytes);
  const std::vector<ChunkIndex>& chunks = reader.summary().chunk_indexes;
  ASSERT_GT(chunks.size(), 5U);  // the shape gives about 15: a loss bound needs several
  for (const std::size_t length : probe_offsets(file.bytes)) {
    // The recording's log times rise with each message, so a chunk holds exactly the
    // messages inside its time range.
    std::size_t in_whole_chunks = 0;
    for (const ChunkIndex& chunk : chunks) {
      if (chunk.chunk_start_offset + chunk.chunk_length > length) continue;
      in_whole_chunks += static_cast<std::size_t>(
          std::count_if(file.messages.begin(), file.messages.end(), [&](const Message& message) {
            return message.log_time >= chunk.message_start_time &&
                   message.log_time <= chunk.message_end_time;
          }));
    }
    const ScanResult result = scan(MemorySource(cut(file.bytes, length)));
    ASSERT_EQ(result.messages.size(), in_whole_chunks) << "cut at " << length;
  }
}

// The writer on a real file, read back from the disk after every message as a crash at that
// moment would leave it: every closed chunk is there, so the loss never exceeds the open chunk
// (the writer flushes each chunk instead of leaving its tail in the stream's buffer).
// Run with and without sync_chunks: fdatasync must not change what the file holds.
class PowerLoss : public ::testing::TestWithParam<bool> {};

TEST_P(PowerLoss, RecorderThatDiesLosesAtMostTheOpenChunk) {
  const std::filesystem::path path =
      std::filesystem::temp_directory_path() /
      ("fl_mcap_power_loss_" + std::to_string(::getpid()) + (GetParam() ? "_sync" : "") + ".mcap");
  WriterOptions options;
  options.sync_chunks = GetParam();
  options.chunk_size = 4 * 1024;  // 1.5 KB frames: a chunk closes every 3 frames
  constexpr std::size_t kFrameBytes = 1500;
  constexpr int kFrames = 40;
  Writer writer(path, options);
  const std::uint16_t channel = writer.add_channel(0, "/camera", "raw");
  std::size_t in_closed_chunks = 0;
  for (int i = 0; i < kFrames; ++i) {
    const Bytes data = frame_payload(i, kFrameBytes);
    const std::uint32_t chunks_before = writer.statistics().chunk_count;
    writer.write_message(
        {channel, static_cast<std::uint32_t>(i), frame_time(i), frame_time(i), data});
    if (writer.statistics().chunk_count != chunks_before) {
      in_closed_chunks = static_cast<std::size_t>(i) + 1;
    }
    const ScanResult on_disk = scan_file(path);
    ASSERT_FALSE(on_disk.complete);
    ASSERT_EQ(on_disk.messages.size(), in_closed_chunks) << "after frame " << i;
    // The open chunk holds less than chunk_size of records: at most 2 frames here.
    ASSERT_LE(static_cast<std::size_t>(i) + 1 - in_closed_chunks, options.chunk_size / kFrameBytes);
  }
  writer.close();
  const ScanResult closed = scan_file(path);
  EXPECT_TRUE(closed.complete) << closed.stop_reason;
  EXPECT_EQ(closed.messages.size(), static_cast<std::size_t>(kFrames));
  std::filesystem::remove(path);
}

INSTANTIATE_TEST_SUITE_P(SyncChunks, PowerLoss, ::testing::Bool(), [](const auto& param_info) {
  return param_info.param ? "Synced" : "Flushed";
});

// sync_chunks really syncs at each closed chunk: /dev/null takes the writes but refuses
// fdatasync (EINVAL), and that refusal surfaces at the first chunk with the file's name.
TEST(SyncChunks, FdatasyncFailureNamesTheFileAtTheFirstChunk) {
  const std::filesystem::path null_device("/dev/null");
  if (!std::filesystem::exists(null_device)) GTEST_SKIP() << "no /dev/null here";
  WriterOptions options;
  options.chunk_size = 4 * 1024;  // 1.5 KB frames: the third frame closes the first chunk
  options.sync_chunks = true;
  Writer writer(null_device, options);
  const std::uint16_t channel = writer.add_channel(0, "/camera", "raw");
  std::string error;
  int frames_written = 0;
  try {
    for (; frames_written < 10; ++frames_written) {
      const Bytes data = frame_payload(frames_written, 1500);
      writer.write_message({channel, static_cast<std::uint32_t>(frames_written),
                            frame_time(frames_written), frame_time(frames_written), data});
    }
  } catch (const std::runtime_error& caught) {
    error = caught.what();
  }
  EXPECT_EQ(frames_written, 2) << "the frame that closes the first chunk (the third) fails";
  EXPECT_NE(error.find("/dev/null"), std::string::npos) << error;
  EXPECT_NE(error.find("fdatasync failed"), std::string::npos) << error;
  EXPECT_NE(error.find("Invalid argument"), std::string::npos) << error;
}

// A full device: the error names the file and the system's reason, at the latest when the
// first chunk is flushed, and the writer neither crashes nor hides it in close().
TEST(DiskFull, FullDeviceIsReportedWithTheFileAndTheReason) {
  const std::filesystem::path full("/dev/full");
  if (!std::filesystem::exists(full)) GTEST_SKIP() << "no /dev/full here";
  WriterOptions options;
  options.chunk_size = 4 * 1024;
  std::string error;
  try {
    Writer writer(full, options);
    const std::uint16_t channel = writer.add_channel(0, "/camera", "raw");
    // 10 frames of 1.5 KB close three 4 KiB chunks: the first flush meets the full device.
    for (int i = 0; i < 10; ++i) {
      const Bytes data = frame_payload(i, 1500);
      writer.write_message(
          {channel, static_cast<std::uint32_t>(i), frame_time(i), frame_time(i), data});
    }
    writer.close();
  } catch (const std::runtime_error& caught) {
    error = caught.what();
  }
  EXPECT_NE(error.find("/dev/full"), std::string::npos) << error;
  EXPECT_NE(error.find("No space left on device"), std::string::npos) << error;
}

class Corruption : public ::testing::TestWithParam<Compression> {};

TEST_P(Corruption, FlippedBytesGiveAnErrorOrTheRightData) {
  WriterOptions options;
  options.compression = GetParam();
  const WrittenFile file = write_recording(options, small_shape());
  int errors = 0;
  // Each field of each record, and payload bytes at a stride, inverted.
  const std::vector<std::size_t> offsets = probe_offsets(file.bytes);
  for (const std::size_t at : offsets) {
    Bytes corrupted = file.bytes;
    corrupted[at] ^= 0xFFU;
    try {
      const Reader reader = open_bytes(corrupted);
      const std::vector<Message> read = reader.read_messages();
      ASSERT_EQ(read.size(), file.messages.size()) << "flip at " << at;
      ASSERT_TRUE(is_prefix(read, file.messages)) << "flip at " << at;
    } catch (const Error& error) {
      ++errors;
      ASSERT_LE(error.offset(), corrupted.size()) << error.what();
    }
    // A scan may recover damaged data (an unknown opcode is skipped, as the spec asks) but
    // then the data section CRC must report it: complete means exactly the written data.
    const ScanResult scanned = scan(MemorySource(corrupted));
    if (scanned.complete) {
      ASSERT_EQ(scanned.messages.size(), file.messages.size()) << "flip at " << at;
      ASSERT_TRUE(is_prefix(scanned.messages, file.messages)) << "flip at " << at;
    } else {
      ASSERT_FALSE(scanned.stop_reason.empty()) << "flip at " << at;
    }
  }
  // Most bytes are covered by a CRC or checked against an index; many flips must be caught.
  EXPECT_GT(errors, static_cast<int>(offsets.size() / 2));
}

TEST_P(Corruption, WithoutCrcChecksNoInputCrashes) {
  WriterOptions options;
  options.compression = GetParam();
  const WrittenFile file = write_recording(options, small_shape());
  const ReaderOptions unchecked = without_crc_checks();
  // Three patterns per byte: all bits, the top bit (lengths become huge) and the low bit.
  for (const std::uint8_t pattern : {std::uint8_t{0xFF}, std::uint8_t{0x80}, std::uint8_t{0x01}}) {
    for (const std::size_t at : probe_offsets(file.bytes)) {
      Bytes corrupted = file.bytes;
      corrupted[at] ^= pattern;
      try {
        const Reader reader = open_bytes(corrupted, unchecked);
        (void)reader.read_messages(time_filter(frame_time(10), ~Timestamp{0}, {kTopics[0]}));
        (void)reader.read_messages();
        for (const AttachmentIndex& index : reader.summary().attachment_indexes) {
          (void)reader.read_attachment(index);
        }
        for (const MetadataIndex& index : reader.summary().metadata_indexes) {
          (void)reader.read_metadata(index);
        }
      } catch (const Error&) {
        // expected for most flips: the point is that nothing else happens
      }
      (void)scan(MemorySource(corrupted), unchecked);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(EachCompression, Corruption,
                         ::testing::Values(Compression::kNone, Compression::kZstd,
                                           Compression::kLz4),
                         compression_test_name);

// Offsets of the chunk fields, from the chunk record's opcode: opcode (1) + length (8), then
// message_start_time (8), message_end_time (8), uncompressed_size (8), uncompressed_crc (4),
// compression (4 + N).
constexpr std::uint64_t kChunkUncompressedSizeAt = 9 + 16;
constexpr std::uint64_t kChunkCrcAt = 9 + 24;
constexpr std::uint64_t kChunkCompressionAt = 9 + 28 + 4;

TEST(MalformedInput, ChunkCrcMismatchIsReportedAtTheChunk) {
  const WrittenFile file = write_recording(compressed(Compression::kNone), small_shape());
  Bytes corrupted = file.bytes;
  const std::uint64_t chunk = first_offset_of(corrupted, Opcode::kChunk);
  // The last byte of the first chunk's records is message payload: only the CRC can notice.
  const Reader intact = open_bytes(file.bytes);
  const ChunkIndex& index = intact.summary().chunk_indexes.at(0);
  ASSERT_EQ(index.chunk_start_offset, chunk);
  corrupted[chunk + index.chunk_length - 1] ^= 0x01U;
  try {
    (void)open_bytes(corrupted).read_messages();
    FAIL() << "CRC mismatch not detected";
  } catch (const Error& error) {
    EXPECT_EQ(error.offset(), chunk);
    EXPECT_NE(std::string(error.what()).find("CRC mismatch"), std::string::npos) << error.what();
  }
  const ScanResult scanned = scan(MemorySource(corrupted));
  EXPECT_EQ(scanned.stopped_at, chunk);
  EXPECT_TRUE(scanned.messages.empty());  // the damaged chunk was the first
  // With CRC checks off the flipped payload comes through: the check is what catches it.
  EXPECT_EQ(open_bytes(corrupted, without_crc_checks()).read_messages().size(), 60U);
}

TEST(MalformedInput, AttachmentAndSummaryCrcMismatchesAreReported) {
  const WrittenFile file = write_recording({}, small_shape());
  Bytes corrupted = file.bytes;
  const std::uint64_t attachment = first_offset_of(corrupted, Opcode::kAttachment);
  corrupted[attachment + kRecordPrefixSize + 8 + 8 + 4] ^= 0x20U;  // first letter of the name
  const Reader reader = open_bytes(corrupted);
  EXPECT_THROW((void)reader.read_attachment(reader.summary().attachment_indexes.at(0)), Error);

  Bytes bad_summary = file.bytes;
  const std::uint64_t summary_start = open_bytes(file.bytes).footer().summary_start;
  bad_summary[summary_start + 20] ^= 0x01U;  // inside the first schema record
  try {
    (void)open_bytes(bad_summary);
    FAIL() << "summary CRC mismatch not detected";
  } catch (const Error& error) {
    EXPECT_EQ(error.offset(), summary_start);
    EXPECT_NE(std::string(error.what()).find("summary CRC"), std::string::npos);
  }
}

TEST(MalformedInput, BadMagicAtEitherEnd) {
  const WrittenFile file = write_recording({}, small_shape());
  Bytes front = file.bytes;
  front[1] = 'X';
  try {
    (void)open_bytes(front);
    FAIL();
  } catch (const Error& error) {
    EXPECT_EQ(error.offset(), 0U);
  }
  EXPECT_EQ(scan(MemorySource(front)).stopped_at, 0U);
  Bytes back = file.bytes;
  back[back.size() - 3] = 'X';
  try {
    (void)open_bytes(back);
    FAIL();
  } catch (const Error& error) {
    EXPECT_EQ(error.offset(), back.size() - kMagic.size());
  }
  EXPECT_THROW((void)open_bytes(Bytes{}), Error);
}

TEST(MalformedInput, RecordLengthBeyondTheFileIsRejectedWithoutAllocating) {
  WriterOptions unchunked;
  unchunked.use_chunks = false;
  const WrittenFile file = write_recording(unchunked, small_shape());
  Bytes corrupted = file.bytes;
  const std::uint64_t message = first_offset_of(corrupted, Opcode::kMessage);
  write_u64(corrupted, message + 1, ~std::uint64_t{0});  // 2^64 - 1 bytes of content
  const ScanResult scanned = scan(MemorySource(corrupted));
  EXPECT_EQ(scanned.stopped_at, message);
  EXPECT_NE(scanned.stop_reason.find("claims"), std::string::npos) << scanned.stop_reason;
  EXPECT_TRUE(scanned.messages.empty());
  // The summary is intact but nothing is indexed, so the reader scans and reports the same.
  try {
    (void)open_bytes(corrupted).read_messages();
    FAIL();
  } catch (const Error& error) {
    EXPECT_EQ(error.offset(), message);
  }
}

TEST(MalformedInput, UnknownCompressionIsNamed) {
  const WrittenFile file = write_recording(compressed(Compression::kZstd), small_shape());
  Bytes corrupted = file.bytes;
  const std::uint64_t chunk = first_offset_of(corrupted, Opcode::kChunk);
  ASSERT_EQ(corrupted[chunk + kChunkCompressionAt], 'z');
  corrupted[chunk + kChunkCompressionAt + 3] = 'x';  // "zstx"
  try {
    (void)open_bytes(corrupted).read_messages();
    FAIL();
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find("unknown compression 'zstx'"), std::string::npos)
        << error.what();
  }
  EXPECT_EQ(scan(MemorySource(corrupted)).stopped_at, chunk);
}

class ChunkSize : public ::testing::TestWithParam<Compression> {};

TEST_P(ChunkSize, DecompressedSizeDifferentFromTheRecordIsAnError) {
  WriterOptions options;
  options.compression = GetParam();
  const WrittenFile file = write_recording(options, small_shape());
  const std::uint64_t chunk = first_offset_of(file.bytes, Opcode::kChunk);
  detail::Cursor size_field(ByteView(file.bytes).subspan(chunk + kChunkUncompressedSizeAt, 8), 0,
                            "test");
  const std::uint64_t size = size_field.u64();
  // One byte more, one byte less, and a forged terabyte (must not be allocated).
  for (const std::uint64_t claimed : {size + 1, size - 1, std::uint64_t{1} << 40}) {
    Bytes corrupted = file.bytes;
    write_u64(corrupted, chunk + kChunkUncompressedSizeAt, claimed);
    try {
      (void)open_bytes(corrupted).read_messages();
      FAIL() << "claimed size " << claimed << " accepted";
    } catch (const Error& error) {
      EXPECT_GE(error.offset(), chunk) << error.what();
      EXPECT_NE(std::string(error.what()).find("uncompressed"), std::string::npos) << error.what();
    }
    EXPECT_EQ(scan(MemorySource(corrupted)).stopped_at, chunk);
  }
  (void)kChunkCrcAt;
}

INSTANTIATE_TEST_SUITE_P(EachCompression, ChunkSize,
                         ::testing::Values(Compression::kNone, Compression::kZstd,
                                           Compression::kLz4),
                         compression_test_name);

}  // namespace
}  // namespace fl::mcap::test
