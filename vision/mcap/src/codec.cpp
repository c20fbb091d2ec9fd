#include "codec.hpp"

#include <lz4frame.h>
#include <zstd.h>

#include <limits>
#include <memory>

namespace fl::mcap {

namespace {

std::string with_offset(const std::string& what, std::uint64_t offset) {
  return "mcap: " + what + " (at byte " + std::to_string(offset) + ")";
}

std::array<std::uint32_t, 256> make_crc_table() {
  std::array<std::uint32_t, 256> table{};
  for (std::uint32_t index = 0; index < 256; ++index) {
    std::uint32_t value = index;
    for (int bit = 0; bit < 8; ++bit) {
      value = (value & 1U) != 0 ? (value >> 1) ^ 0xEDB88320U : value >> 1;
    }
    table[index] = value;
  }
  return table;
}

}  // namespace

Error::Error(const std::string& reason, std::uint64_t offset)
    : std::runtime_error(with_offset(reason, offset)), reason_(reason), offset_(offset) {}

std::uint32_t crc32(ByteView data, std::uint32_t crc) {
  static const std::array<std::uint32_t, 256> table = make_crc_table();
  std::uint32_t state = ~crc;
  for (std::uint8_t byte : data) {
    state = table[(state ^ byte) & 0xFFU] ^ (state >> 8);
  }
  return ~state;
}

std::string_view compression_name(Compression compression) {
  switch (compression) {
    case Compression::kZstd:
      return "zstd";
    case Compression::kLz4:
      return "lz4";
    case Compression::kNone:
      break;
  }
  return "";
}

std::optional<Compression> parse_compression(std::string_view name) {
  if (name.empty()) return Compression::kNone;
  if (name == "zstd") return Compression::kZstd;
  if (name == "lz4") return Compression::kLz4;
  return std::nullopt;
}

}  // namespace fl::mcap

namespace fl::mcap::detail {

void ByteWriter::little_endian(std::uint64_t value, int byte_count) {
  for (int index = 0; index < byte_count; ++index) {
    out_.push_back(static_cast<std::uint8_t>(value >> (8 * index)));
  }
}

void ByteWriter::string(std::string_view text) {
  if (text.size() > std::numeric_limits<std::uint32_t>::max()) {
    throw std::length_error("mcap: string longer than a uint32 length prefix allows");
  }
  u32(static_cast<std::uint32_t>(text.size()));
  out_.insert(out_.end(), text.begin(), text.end());
}

void ByteWriter::bytes32(ByteView bytes) {
  if (bytes.size() > std::numeric_limits<std::uint32_t>::max()) {
    throw std::length_error("mcap: byte field longer than a uint32 length prefix allows");
  }
  u32(static_cast<std::uint32_t>(bytes.size()));
  raw(bytes);
}

void ByteWriter::bytes64(ByteView bytes) {
  u64(bytes.size());
  raw(bytes);
}

// Maps carry a uint32 byte length, so the entries are written first and the length patched.
void ByteWriter::string_map(const std::map<std::string, std::string>& map) {
  const std::size_t length_at = out_.size();
  u32(0);
  for (const auto& [key, value] : map) {
    string(key);
    string(value);
  }
  const std::uint64_t length = out_.size() - length_at - 4;
  if (length > std::numeric_limits<std::uint32_t>::max()) {
    throw std::length_error("mcap: map longer than a uint32 length prefix allows");
  }
  for (int index = 0; index < 4; ++index) {
    out_[length_at + static_cast<std::size_t>(index)] =
        static_cast<std::uint8_t>(length >> (8 * index));
  }
}

void ByteWriter::u16_u64_map(const std::map<std::uint16_t, std::uint64_t>& map) {
  // 10 bytes per entry and at most 65536 keys: always fits the uint32 length.
  u32(static_cast<std::uint32_t>(map.size() * 10));
  for (const auto& [key, value] : map) {
    u16(key);
    u64(value);
  }
}

void Cursor::fail(const std::string& what) const {
  throw Error(std::string(context_) + ": " + what, offset());
}

void Cursor::need(std::uint64_t count, std::string_view field) {
  if (count > remaining()) {
    fail("truncated " + std::string(field) + ": needs " + std::to_string(count) +
         " bytes, record has " + std::to_string(remaining()) + " left");
  }
}

std::uint64_t Cursor::little_endian(int byte_count) {
  std::uint64_t value = 0;
  for (int index = 0; index < byte_count; ++index) {
    value |= static_cast<std::uint64_t>(bytes_[position_ + static_cast<std::size_t>(index)])
             << (8 * index);
  }
  position_ += static_cast<std::uint64_t>(byte_count);
  return value;
}

std::uint8_t Cursor::u8() {
  need(1, "uint8");
  return static_cast<std::uint8_t>(little_endian(1));
}
std::uint16_t Cursor::u16() {
  need(2, "uint16");
  return static_cast<std::uint16_t>(little_endian(2));
}
std::uint32_t Cursor::u32() {
  need(4, "uint32");
  return static_cast<std::uint32_t>(little_endian(4));
}
std::uint64_t Cursor::u64() {
  need(8, "uint64");
  return little_endian(8);
}

ByteView Cursor::view(std::uint64_t length) {
  need(length, "byte field");
  ByteView result = bytes_.subspan(position_, length);
  position_ += length;
  return result;
}

std::string Cursor::string() {
  const std::uint32_t length = u32();
  need(length, "string");
  ByteView text = view(length);
  return {text.begin(), text.end()};
}

Bytes Cursor::bytes32() {
  const std::uint32_t length = u32();
  ByteView data = view(length);
  return {data.begin(), data.end()};
}

Bytes Cursor::bytes64() {
  const std::uint64_t length = u64();
  ByteView data = view(length);
  return {data.begin(), data.end()};
}

std::map<std::string, std::string> Cursor::string_map() {
  const std::uint32_t length = u32();
  need(length, "map");
  Cursor entries(bytes_.subspan(position_, length), offset(), context_);
  position_ += length;
  std::map<std::string, std::string> map;
  while (entries.remaining() > 0) {
    std::string key = entries.string();
    map.insert_or_assign(std::move(key), entries.string());
  }
  return map;
}

std::map<std::uint16_t, std::uint64_t> Cursor::u16_u64_map() {
  const std::uint32_t length = u32();
  need(length, "map");
  if (length % 10 != 0) {
    fail("map<uint16, uint64> length " + std::to_string(length) + " is not a multiple of 10");
  }
  Cursor entries(bytes_.subspan(position_, length), offset(), context_);
  position_ += length;
  std::map<std::uint16_t, std::uint64_t> map;
  while (entries.remaining() > 0) {
    const std::uint16_t key = entries.u16();
    map.insert_or_assign(key, entries.u64());
  }
  return map;
}

std::string_view opcode_name(std::uint8_t opcode) {
  switch (static_cast<Opcode>(opcode)) {
    case Opcode::kHeader:
      return "header";
    case Opcode::kFooter:
      return "footer";
    case Opcode::kSchema:
      return "schema";
    case Opcode::kChannel:
      return "channel";
    case Opcode::kMessage:
      return "message";
    case Opcode::kChunk:
      return "chunk";
    case Opcode::kMessageIndex:
      return "message index";
    case Opcode::kChunkIndex:
      return "chunk index";
    case Opcode::kAttachment:
      return "attachment";
    case Opcode::kAttachmentIndex:
      return "attachment index";
    case Opcode::kStatistics:
      return "statistics";
    case Opcode::kMetadata:
      return "metadata";
    case Opcode::kMetadataIndex:
      return "metadata index";
    case Opcode::kSummaryOffset:
      return "summary offset";
    case Opcode::kDataEnd:
      return "data end";
  }
  return "unknown record";
}

void append_record(Bytes& out, Opcode opcode, ByteView content) {
  ByteWriter writer(out);
  writer.u8(static_cast<std::uint8_t>(opcode));
  writer.u64(content.size());
  writer.raw(content);
}

void encode(ByteWriter& out, const Header& record) {
  out.string(record.profile);
  out.string(record.library);
}

void encode(ByteWriter& out, const Footer& record) {
  out.u64(record.summary_start);
  out.u64(record.summary_offset_start);
  out.u32(record.summary_crc);
}

void encode(ByteWriter& out, const Schema& record) {
  out.u16(record.id);
  out.string(record.name);
  out.string(record.encoding);
  out.bytes32(record.data);
}

void encode(ByteWriter& out, const Channel& record) {
  out.u16(record.id);
  out.u16(record.schema_id);
  out.string(record.topic);
  out.string(record.message_encoding);
  out.string_map(record.metadata);
}

void encode_message(ByteWriter& out, std::uint16_t channel_id, std::uint32_t sequence,
                    Timestamp log_time, Timestamp publish_time, ByteView data) {
  out.u16(channel_id);
  out.u32(sequence);
  out.u64(log_time);
  out.u64(publish_time);
  out.raw(data);
}

void encode(ByteWriter& out, const ChunkIndex& record) {
  out.u64(record.message_start_time);
  out.u64(record.message_end_time);
  out.u64(record.chunk_start_offset);
  out.u64(record.chunk_length);
  out.u16_u64_map(record.message_index_offsets);
  out.u64(record.message_index_length);
  out.string(record.compression);
  out.u64(record.compressed_size);
  out.u64(record.uncompressed_size);
}

void encode_attachment(ByteWriter& out, const Attachment& record) {
  const std::size_t start = out.size();
  out.u64(record.log_time);
  out.u64(record.create_time);
  out.string(record.name);
  out.string(record.media_type);
  out.bytes64(record.data);
  out.u32(crc32(ByteView(out.buffer()).subspan(start)));
}

void encode(ByteWriter& out, const AttachmentIndex& record) {
  out.u64(record.offset);
  out.u64(record.length);
  out.u64(record.log_time);
  out.u64(record.create_time);
  out.u64(record.data_size);
  out.string(record.name);
  out.string(record.media_type);
}

void encode(ByteWriter& out, const Metadata& record) {
  out.string(record.name);
  out.string_map(record.metadata);
}

void encode(ByteWriter& out, const MetadataIndex& record) {
  out.u64(record.offset);
  out.u64(record.length);
  out.string(record.name);
}

void encode(ByteWriter& out, const Statistics& record) {
  out.u64(record.message_count);
  out.u16(record.schema_count);
  out.u32(record.channel_count);
  out.u32(record.attachment_count);
  out.u32(record.metadata_count);
  out.u32(record.chunk_count);
  out.u64(record.message_start_time);
  out.u64(record.message_end_time);
  out.u16_u64_map(record.channel_message_counts);
}

void encode(ByteWriter& out, const SummaryOffset& record) {
  out.u8(static_cast<std::uint8_t>(record.group_opcode));
  out.u64(record.group_start);
  out.u64(record.group_length);
}

Header decode_header(Cursor& in) {
  Header record;
  record.profile = in.string();
  record.library = in.string();
  return record;
}

Footer decode_footer(Cursor& in) {
  Footer record;
  record.summary_start = in.u64();
  record.summary_offset_start = in.u64();
  record.summary_crc = in.u32();
  return record;
}

Schema decode_schema(Cursor& in) {
  Schema record;
  record.id = in.u16();
  record.name = in.string();
  record.encoding = in.string();
  record.data = in.bytes32();
  return record;
}

Channel decode_channel(Cursor& in) {
  Channel record;
  record.id = in.u16();
  record.schema_id = in.u16();
  record.topic = in.string();
  record.message_encoding = in.string();
  record.metadata = in.string_map();
  return record;
}

Message decode_message(Cursor& in) {
  Message record;
  record.channel_id = in.u16();
  record.sequence = in.u32();
  record.log_time = in.u64();
  record.publish_time = in.u64();
  ByteView data = in.view(in.remaining());  // the message data is the rest of the record
  record.data.assign(data.begin(), data.end());
  return record;
}

ChunkFields decode_chunk(Cursor& in) {
  ChunkFields record;
  record.message_start_time = in.u64();
  record.message_end_time = in.u64();
  record.uncompressed_size = in.u64();
  record.uncompressed_crc = in.u32();
  record.compression = in.string();
  const std::uint64_t length = in.u64();
  record.records_offset = in.offset();
  record.records = in.view(length);
  return record;
}

MessageIndexFields decode_message_index(Cursor& in) {
  MessageIndexFields record;
  record.channel_id = in.u16();
  const std::uint32_t length = in.u32();
  if (length % 16 != 0) {
    in.fail("message index array length " + std::to_string(length) + " is not a multiple of 16");
  }
  Cursor entries(in.view(length), in.offset() - length, "message index");
  record.entries.reserve(length / 16);
  while (entries.remaining() > 0) {
    MessageIndexEntry entry;
    entry.log_time = entries.u64();
    entry.offset = entries.u64();
    record.entries.push_back(entry);
  }
  return record;
}

ChunkIndex decode_chunk_index(Cursor& in) {
  ChunkIndex record;
  record.message_start_time = in.u64();
  record.message_end_time = in.u64();
  record.chunk_start_offset = in.u64();
  record.chunk_length = in.u64();
  record.message_index_offsets = in.u16_u64_map();
  record.message_index_length = in.u64();
  record.compression = in.string();
  record.compressed_size = in.u64();
  record.uncompressed_size = in.u64();
  return record;
}

Attachment decode_attachment(ByteView body, std::uint64_t base, bool validate_crc) {
  Cursor in(body, base, "attachment");
  Attachment record;
  record.log_time = in.u64();
  record.create_time = in.u64();
  record.name = in.string();
  record.media_type = in.string();
  record.data = in.bytes64();
  const std::uint64_t covered = in.offset() - base;
  const std::uint32_t stored_crc = in.u32();
  if (validate_crc && stored_crc != 0) {
    const std::uint32_t actual = crc32(body.subspan(0, covered));
    if (actual != stored_crc) {
      throw Error("attachment '" + record.name + "' CRC mismatch: stored " +
                      std::to_string(stored_crc) + ", computed " + std::to_string(actual),
                  base);
    }
  }
  return record;
}

AttachmentIndex decode_attachment_index(Cursor& in) {
  AttachmentIndex record;
  record.offset = in.u64();
  record.length = in.u64();
  record.log_time = in.u64();
  record.create_time = in.u64();
  record.data_size = in.u64();
  record.name = in.string();
  record.media_type = in.string();
  return record;
}

Metadata decode_metadata(Cursor& in) {
  Metadata record;
  record.name = in.string();
  record.metadata = in.string_map();
  return record;
}

MetadataIndex decode_metadata_index(Cursor& in) {
  MetadataIndex record;
  record.offset = in.u64();
  record.length = in.u64();
  record.name = in.string();
  return record;
}

Statistics decode_statistics(Cursor& in) {
  Statistics record;
  record.message_count = in.u64();
  record.schema_count = in.u16();
  record.channel_count = in.u32();
  record.attachment_count = in.u32();
  record.metadata_count = in.u32();
  record.chunk_count = in.u32();
  record.message_start_time = in.u64();
  record.message_end_time = in.u64();
  record.channel_message_counts = in.u16_u64_map();
  return record;
}

SummaryOffset decode_summary_offset(Cursor& in) {
  SummaryOffset record;
  record.group_opcode = static_cast<Opcode>(in.u8());
  record.group_start = in.u64();
  record.group_length = in.u64();
  return record;
}

std::uint32_t decode_data_end(Cursor& in) { return in.u32(); }

namespace {

struct Lz4DecompressionDeleter {
  void operator()(LZ4F_dctx* context) const { LZ4F_freeDecompressionContext(context); }
};

// Upper bounds on how far a valid stream can expand: a zstd RLE block of 128 KiB costs
// 4 bytes (header + byte), so 32768:1; LZ4 copies at most 255 bytes per length byte, so
// 255:1. Anything claiming more is corrupt, which stops a forged size from allocating.
constexpr std::uint64_t kZstdMaxExpansion = 32768;
constexpr std::uint64_t kLz4MaxExpansion = 256;
constexpr std::uint64_t kExpansionSlack = 1024;  // covers tiny frames with fixed headers

}  // namespace

Bytes compress(Compression compression, ByteView records, int zstd_level) {
  Bytes out;
  switch (compression) {
    case Compression::kNone:
      out.assign(records.begin(), records.end());
      return out;
    case Compression::kZstd: {
      out.resize(ZSTD_compressBound(records.size()));
      const std::size_t written =
          ZSTD_compress(out.data(), out.size(), records.data(), records.size(), zstd_level);
      if (ZSTD_isError(written) != 0U) {
        throw std::runtime_error(std::string("mcap: zstd compression failed: ") +
                                 ZSTD_getErrorName(written));
      }
      out.resize(written);
      return out;
    }
    case Compression::kLz4: {
      LZ4F_preferences_t preferences{};
      // The frame records the content size so readers can check it before decoding.
      preferences.frameInfo.contentSize = records.size();
      out.resize(LZ4F_compressFrameBound(records.size(), &preferences));
      const std::size_t written =
          LZ4F_compressFrame(out.data(), out.size(), records.data(), records.size(), &preferences);
      if (LZ4F_isError(written) != 0U) {
        throw std::runtime_error(std::string("mcap: lz4 compression failed: ") +
                                 LZ4F_getErrorName(written));
      }
      out.resize(written);
      return out;
    }
  }
  return out;
}

Bytes decompress(std::string_view compression, ByteView payload, std::uint64_t uncompressed_size,
                 std::uint64_t offset, std::uint64_t max_uncompressed) {
  const std::optional<Compression> kind = parse_compression(compression);
  if (!kind) {
    throw Error("chunk uses unknown compression '" + std::string(compression) + "'", offset);
  }
  auto size_error = [&](const std::string& why) {
    return Error("chunk (" + std::string(compression_name(*kind)) + ") uncompressed_size " +
                     std::to_string(uncompressed_size) + " " + why,
                 offset);
  };
  if (uncompressed_size > max_uncompressed) {
    throw size_error("exceeds the reader limit of " + std::to_string(max_uncompressed));
  }
  if (*kind == Compression::kNone) {
    if (payload.size() != uncompressed_size) {
      throw size_error("differs from the stored size " + std::to_string(payload.size()));
    }
    return Bytes(payload.begin(), payload.end());
  }
  const std::uint64_t expansion =
      *kind == Compression::kZstd ? kZstdMaxExpansion : kLz4MaxExpansion;
  if (uncompressed_size / expansion > payload.size() + kExpansionSlack) {
    throw size_error("is larger than " + std::to_string(payload.size()) +
                     " compressed bytes can expand to");
  }
  // The frames' own content sizes, when recorded, are checked before allocating.
  if (*kind == Compression::kZstd) {
    std::uint64_t frames_size = 0;
    bool size_known = true;
    for (std::size_t at = 0; at < payload.size();) {
      const std::size_t frame_bytes =
          ZSTD_findFrameCompressedSize(payload.data() + at, payload.size() - at);
      if (ZSTD_isError(frame_bytes) != 0U) {
        throw Error(std::string("zstd chunk holds no whole zstd frame here: ") +
                        ZSTD_getErrorName(frame_bytes),
                    offset + at);
      }
      const unsigned long long content =
          ZSTD_getFrameContentSize(payload.data() + at, payload.size() - at);
      if (content == ZSTD_CONTENTSIZE_ERROR) {
        throw Error("zstd frame header is invalid", offset + at);
      }
      if (content == ZSTD_CONTENTSIZE_UNKNOWN) {
        size_known = false;
      } else {
        frames_size += content;
      }
      at += frame_bytes;
    }
    if (size_known && frames_size != uncompressed_size) {
      throw size_error("differs from the zstd frames' content size " + std::to_string(frames_size));
    }
  } else {
    LZ4F_dctx* raw_probe = nullptr;
    if (LZ4F_isError(LZ4F_createDecompressionContext(&raw_probe, LZ4F_VERSION)) != 0U) {
      throw std::runtime_error("mcap: cannot create an lz4 decompression context");
    }
    std::unique_ptr<LZ4F_dctx, Lz4DecompressionDeleter> probe(raw_probe);
    LZ4F_frameInfo_t info{};
    std::size_t header_bytes = payload.size();
    const std::size_t result = LZ4F_getFrameInfo(probe.get(), &info, payload.data(), &header_bytes);
    if (LZ4F_isError(result) != 0U) {
      throw Error(
          std::string("lz4 chunk does not start with an lz4 frame: ") + LZ4F_getErrorName(result),
          offset);
    }
    if (info.contentSize != 0 && info.contentSize != uncompressed_size) {  // 0: not recorded
      throw size_error("differs from the lz4 frame content size " +
                       std::to_string(info.contentSize));
    }
  }
  Bytes out(uncompressed_size);
  if (*kind == Compression::kZstd) {
    // One context per thread: creating one per chunk costs more than small chunks do.
    struct DecompressionDeleter {
      void operator()(ZSTD_DCtx* context) const { ZSTD_freeDCtx(context); }
    };
    thread_local const std::unique_ptr<ZSTD_DCtx, DecompressionDeleter> context(ZSTD_createDCtx());
    if (!context) throw std::runtime_error("mcap: cannot create a zstd decompression context");
    const std::size_t written =
        ZSTD_decompressDCtx(context.get(), out.data(), out.size(), payload.data(), payload.size());
    if (ZSTD_isError(written) != 0U) {
      throw Error(std::string("zstd chunk does not decompress: ") + ZSTD_getErrorName(written) +
                      " (a chunk larger than uncompressed_size reports as too small a buffer)",
                  offset);
    }
    if (written != uncompressed_size) {
      throw size_error("differs from the decompressed size " + std::to_string(written));
    }
    return out;
  }
  LZ4F_dctx* raw_context = nullptr;
  if (LZ4F_isError(LZ4F_createDecompressionContext(&raw_context, LZ4F_VERSION)) != 0U) {
    throw std::runtime_error("mcap: cannot create an lz4 decompression context");
  }
  std::unique_ptr<LZ4F_dctx, Lz4DecompressionDeleter> context(raw_context);
  std::size_t consumed_total = 0;
  std::size_t produced_total = 0;
  std::size_t hint = 1;  // non-zero until the frame ends
  while (hint != 0 && consumed_total < payload.size()) {
    std::size_t produced = out.size() - produced_total;
    std::size_t consumed = payload.size() - consumed_total;
    // A zero-capacity output still lets LZ4 read headers and report the frame end.
    std::uint8_t spare = 0;
    std::uint8_t* destination = produced == 0 ? &spare : out.data() + produced_total;
    hint = LZ4F_decompress(context.get(), destination, &produced, payload.data() + consumed_total,
                           &consumed, nullptr);
    if (LZ4F_isError(hint) != 0U) {
      throw Error(std::string("lz4 chunk does not decompress: ") + LZ4F_getErrorName(hint),
                  offset + consumed_total);
    }
    if (produced == 0 && consumed == 0) break;  // no progress: output full but frame goes on
    consumed_total += consumed;
    produced_total += produced;
  }
  if (hint != 0) {
    throw size_error(consumed_total < payload.size() ? "is smaller than the lz4 frame's content"
                                                     : "not reached: the lz4 frame is incomplete");
  }
  if (consumed_total != payload.size()) {
    throw Error("lz4 chunk has " + std::to_string(payload.size() - consumed_total) +
                    " bytes after the end of its frame",
                offset + consumed_total);
  }
  if (produced_total != uncompressed_size) {
    throw size_error("differs from the decompressed size " + std::to_string(produced_total));
  }
  return out;
}

}  // namespace fl::mcap::detail
