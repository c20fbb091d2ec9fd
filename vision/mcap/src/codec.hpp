#pragma once
// Internal: record content encoding and bounds-checked decoding shared by writer and reader.

#include <cstdint>
#include <string>
#include <string_view>

#include "fl/mcap/records.hpp"

namespace fl::mcap::detail {

// Appends little-endian fields to a byte buffer.
class ByteWriter {
 public:
  explicit ByteWriter(Bytes& out) : out_(out) {}
  void u8(std::uint8_t value) { out_.push_back(value); }
  void u16(std::uint16_t value) { little_endian(value, 2); }
  void u32(std::uint32_t value) { little_endian(value, 4); }
  void u64(std::uint64_t value) { little_endian(value, 8); }
  void raw(ByteView bytes) { out_.insert(out_.end(), bytes.begin(), bytes.end()); }
  void string(std::string_view text);  // uint32 length + bytes
  void bytes32(ByteView bytes);        // uint32 length + bytes
  void bytes64(ByteView bytes);        // uint64 length + bytes
  void string_map(const std::map<std::string, std::string>& map);
  void u16_u64_map(const std::map<std::uint16_t, std::uint64_t>& map);
  std::size_t size() const { return out_.size(); }
  Bytes& buffer() { return out_; }

 private:
  void little_endian(std::uint64_t value, int byte_count);
  Bytes& out_;
};

// Reads fields from a byte range that starts at file offset `base`; any read past the end
// throws Error naming `context` and the file offset, so no length field is trusted.
class Cursor {
 public:
  Cursor(ByteView bytes, std::uint64_t base, std::string_view context)
      : bytes_(bytes), base_(base), context_(context) {}
  std::uint8_t u8();
  std::uint16_t u16();
  std::uint32_t u32();
  std::uint64_t u64();
  std::string string();
  Bytes bytes32();
  Bytes bytes64();
  ByteView view(std::uint64_t length);
  std::map<std::string, std::string> string_map();
  std::map<std::uint16_t, std::uint64_t> u16_u64_map();
  std::uint64_t remaining() const { return bytes_.size() - position_; }
  std::uint64_t offset() const { return base_ + position_; }  // file offset of the next byte
  [[noreturn]] void fail(const std::string& what) const;

 private:
  void need(std::uint64_t count, std::string_view field);
  std::uint64_t little_endian(int byte_count);
  ByteView bytes_;
  std::uint64_t base_;
  std::string_view context_;
  std::uint64_t position_ = 0;
};

std::string_view opcode_name(std::uint8_t opcode);

// Appends opcode, length and content; `content` is the record body.
void append_record(Bytes& out, Opcode opcode, ByteView content);

// Record bodies (the part after opcode and length).
void encode(ByteWriter& out, const Header& record);
void encode(ByteWriter& out, const Footer& record);
void encode(ByteWriter& out, const Schema& record);
void encode(ByteWriter& out, const Channel& record);
void encode_message(ByteWriter& out, std::uint16_t channel_id, std::uint32_t sequence,
                    Timestamp log_time, Timestamp publish_time, ByteView data);
void encode(ByteWriter& out, const ChunkIndex& record);
void encode_attachment(ByteWriter& out, const Attachment& record);  // includes its CRC
void encode(ByteWriter& out, const AttachmentIndex& record);
void encode(ByteWriter& out, const Metadata& record);
void encode(ByteWriter& out, const MetadataIndex& record);
void encode(ByteWriter& out, const Statistics& record);
void encode(ByteWriter& out, const SummaryOffset& record);

Header decode_header(Cursor& in);
Footer decode_footer(Cursor& in);
Schema decode_schema(Cursor& in);
Channel decode_channel(Cursor& in);
Message decode_message(Cursor& in);
struct ChunkFields {
  Timestamp message_start_time = 0;
  Timestamp message_end_time = 0;
  std::uint64_t uncompressed_size = 0;
  std::uint32_t uncompressed_crc = 0;
  std::string compression;
  ByteView records;
  std::uint64_t records_offset = 0;  // file offset of the compressed records
};
ChunkFields decode_chunk(Cursor& in);
struct MessageIndexFields {
  std::uint16_t channel_id = 0;
  std::vector<MessageIndexEntry> entries;
};
MessageIndexFields decode_message_index(Cursor& in);
ChunkIndex decode_chunk_index(Cursor& in);
// Checks the stored CRC (when non-zero) over the record body `body` starting at `base`.
Attachment decode_attachment(ByteView body, std::uint64_t base, bool validate_crc);
AttachmentIndex decode_attachment_index(Cursor& in);
Metadata decode_metadata(Cursor& in);
MetadataIndex decode_metadata_index(Cursor& in);
Statistics decode_statistics(Cursor& in);
SummaryOffset decode_summary_offset(Cursor& in);
std::uint32_t decode_data_end(Cursor& in);

// Chunk payloads.
Bytes compress(Compression compression, ByteView records, int zstd_level);
// Decompresses exactly `uncompressed_size` bytes; `offset` is the payload's file offset for
// errors. Refuses sizes above `max_uncompressed` or beyond what the format can expand to.
Bytes decompress(std::string_view compression, ByteView payload, std::uint64_t uncompressed_size,
                 std::uint64_t offset, std::uint64_t max_uncompressed);

}  // namespace fl::mcap::detail
