#pragma once
// MCAP record types, as the public specification (mcap.dev/spec, major version 0) lays them
// out. Every field keeps the specification's name; all integers are little-endian on disk.

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace fl::mcap {

using Timestamp = std::uint64_t;  // nanoseconds since a user-chosen epoch
using Bytes = std::vector<std::uint8_t>;
using ByteView = std::span<const std::uint8_t>;

// 0x89 "MCAP" '0' "\r\n": the leading and trailing magic; '0' is the major version.
inline constexpr std::array<std::uint8_t, 8> kMagic = {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};
// Opcode (1 byte) and content length (uint64) precede every record's content.
inline constexpr std::uint64_t kRecordPrefixSize = 9;

enum class Opcode : std::uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kMessageIndex = 0x07,
  kChunkIndex = 0x08,
  kAttachment = 0x09,
  kAttachmentIndex = 0x0A,
  kStatistics = 0x0B,
  kMetadata = 0x0C,
  kMetadataIndex = 0x0D,
  kSummaryOffset = 0x0E,
  kDataEnd = 0x0F,
};

// Chunk compression; on disk the strings "", "zstd" and "lz4" (LZ4 frame format).
enum class Compression { kNone, kZstd, kLz4 };
std::string_view compression_name(Compression compression);
// Empty when the name is not one this library decodes.
std::optional<Compression> parse_compression(std::string_view name);

// Every malformed input ends in this error: what was wrong and the file byte offset where.
class Error : public std::runtime_error {
 public:
  Error(const std::string& reason, std::uint64_t offset);
  std::uint64_t offset() const { return offset_; }
  const std::string& reason() const { return reason_; }  // what() without prefix and offset

 private:
  std::string reason_;
  std::uint64_t offset_;
};

// CRC-32 as MCAP uses it (IEEE 802.3 / zlib: reflected polynomial 0xEDB88320). Pass the
// previous result as `crc` to continue over several pieces.
std::uint32_t crc32(ByteView data, std::uint32_t crc = 0);

struct Header {
  std::string profile;
  std::string library;
};

struct Footer {
  std::uint64_t summary_start = 0;
  std::uint64_t summary_offset_start = 0;
  std::uint32_t summary_crc = 0;
};

struct Schema {
  std::uint16_t id = 0;  // 0 is invalid for a schema record
  std::string name;
  std::string encoding;  // e.g. "omgidl", "ros2msg", "jsonschema"; empty: no schema
  Bytes data;
};

struct Channel {
  std::uint16_t id = 0;
  std::uint16_t schema_id = 0;  // 0: the channel has no schema
  std::string topic;
  std::string message_encoding;  // e.g. "cdr", "json"
  std::map<std::string, std::string> metadata;
};

struct Message {
  std::uint16_t channel_id = 0;
  std::uint32_t sequence = 0;
  Timestamp log_time = 0;
  Timestamp publish_time = 0;
  Bytes data;
};

struct MessageIndexEntry {
  Timestamp log_time = 0;
  std::uint64_t offset = 0;  // into the chunk's uncompressed records
};

struct ChunkIndex {
  Timestamp message_start_time = 0;
  Timestamp message_end_time = 0;
  std::uint64_t chunk_start_offset = 0;
  std::uint64_t chunk_length = 0;  // including opcode and length prefix
  std::map<std::uint16_t, std::uint64_t> message_index_offsets;  // channel -> file offset
  std::uint64_t message_index_length = 0;
  std::string compression;
  std::uint64_t compressed_size = 0;
  std::uint64_t uncompressed_size = 0;
};

struct Attachment {
  Timestamp log_time = 0;
  Timestamp create_time = 0;
  std::string name;
  std::string media_type;
  Bytes data;
};

struct AttachmentIndex {
  std::uint64_t offset = 0;
  std::uint64_t length = 0;
  Timestamp log_time = 0;
  Timestamp create_time = 0;
  std::uint64_t data_size = 0;
  std::string name;
  std::string media_type;
};

struct Metadata {
  std::string name;
  std::map<std::string, std::string> metadata;
};

struct MetadataIndex {
  std::uint64_t offset = 0;
  std::uint64_t length = 0;
  std::string name;
};

struct Statistics {
  std::uint64_t message_count = 0;
  std::uint16_t schema_count = 0;
  std::uint32_t channel_count = 0;
  std::uint32_t attachment_count = 0;
  std::uint32_t metadata_count = 0;
  std::uint32_t chunk_count = 0;
  Timestamp message_start_time = 0;
  Timestamp message_end_time = 0;
  std::map<std::uint16_t, std::uint64_t> channel_message_counts;
};

struct SummaryOffset {
  Opcode group_opcode = Opcode::kHeader;
  std::uint64_t group_start = 0;
  std::uint64_t group_length = 0;
};

}  // namespace fl::mcap
