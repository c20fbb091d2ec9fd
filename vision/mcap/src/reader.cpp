#include "fl/mcap/reader.hpp"

#include <algorithm>
#include <cstring>
#include <set>
#include <stdexcept>
#include <tuple>

#include "codec.hpp"

namespace fl::mcap {

using detail::Cursor;

namespace {

// Magic (8) + footer record (9 + 20) + magic (8): nothing shorter can hold a footer.
constexpr std::uint64_t kFooterRecordSize = kRecordPrefixSize + 20;
constexpr std::uint64_t kMinimumFileSize = kMagic.size() + kFooterRecordSize + kMagic.size();

std::string opcode_text(std::uint8_t opcode) {
  return std::string(detail::opcode_name(opcode)) + " (opcode " + std::to_string(opcode) + ")";
}

bool is_magic(ByteView bytes) {
  return bytes.size() == kMagic.size() && std::equal(bytes.begin(), bytes.end(), kMagic.begin());
}

// One record inside an in-memory range, its content bounds-checked against the range.
struct RecordView {
  std::uint8_t opcode = 0;
  ByteView content;
  std::uint64_t offset = 0;  // of the opcode, in the numbering the caller chose
};

RecordView next_record(ByteView range, std::uint64_t& position, std::uint64_t base,
                       const char* where) {
  const std::uint64_t left = range.size() - position;
  const std::uint64_t offset = base + position;
  if (left < kRecordPrefixSize) {
    throw Error(std::string(where) + ": truncated record prefix, " + std::to_string(left) +
                    " bytes left of 9",
                offset);
  }
  Cursor prefix(range.subspan(position, kRecordPrefixSize), offset, where);
  RecordView record;
  record.opcode = prefix.u8();
  const std::uint64_t length = prefix.u64();
  record.offset = offset;
  if (record.opcode == 0) throw Error(std::string(where) + ": opcode 0 is not valid", offset);
  if (length > left - kRecordPrefixSize) {
    throw Error(std::string(where) + ": " + opcode_text(record.opcode) + " claims " +
                    std::to_string(length) + " content bytes, only " +
                    std::to_string(left - kRecordPrefixSize) + " remain",
                offset);
  }
  record.content = range.subspan(position + kRecordPrefixSize, length);
  position += kRecordPrefixSize + length;
  return record;
}

// The records of a chunk, decompressed and CRC-checked; errors name the chunk's offset.
Bytes chunk_records(const detail::ChunkFields& chunk, std::uint64_t chunk_offset,
                    const ReaderOptions& options) {
  Bytes records = detail::decompress(chunk.compression, chunk.records, chunk.uncompressed_size,
                                     chunk.records_offset, options.max_chunk_bytes);
  if (options.validate_crcs && chunk.uncompressed_crc != 0) {
    const std::uint32_t actual = crc32(records);
    if (actual != chunk.uncompressed_crc) {
      throw Error("chunk CRC mismatch: stored " + std::to_string(chunk.uncompressed_crc) +
                      ", computed " + std::to_string(actual),
                  chunk_offset);
    }
  }
  return records;
}

// Errors inside decompressed data carry the chunk's file offset plus the inner position.
[[noreturn]] void rethrow_in_chunk(const Error& error, std::uint64_t chunk_offset) {
  throw Error("inside the chunk, at uncompressed offset " + std::to_string(error.offset()) + ": " +
                  error.reason(),
              chunk_offset);
}

}  // namespace

FileSource::FileSource(const std::filesystem::path& path) : file_(path, std::ios::binary) {
  if (!file_) throw std::runtime_error("mcap: cannot open " + path.string());
  file_.seekg(0, std::ios::end);
  size_ = static_cast<std::uint64_t>(file_.tellg());
}

void FileSource::read(std::uint64_t offset, std::span<std::uint8_t> out) const {
  file_.clear();
  file_.seekg(static_cast<std::streamoff>(offset));
  file_.read(reinterpret_cast<char*>(out.data()), static_cast<std::streamsize>(out.size()));
  if (!file_) throw Error("file read failed", offset);
}

void MemorySource::read(std::uint64_t offset, std::span<std::uint8_t> out) const {
  if (offset > bytes_.size() || out.size() > bytes_.size() - offset) {
    throw Error("read past the end of the buffer", offset);
  }
  if (out.empty()) return;  // memcpy wants valid pointers even for zero bytes
  std::memcpy(out.data(), bytes_.data() + offset, out.size());
}

// ---------------------------------------------------------------------------------------
// Linear scan

namespace {

class Scanner {
 public:
  Scanner(const ByteSource& source, const ReaderOptions& options, ScanResult& result)
      : source_(source), options_(options), result_(result) {}

  void run() {
    const std::uint64_t size = source_.size();
    if (size < kMagic.size() || !is_magic(read(0, kMagic.size()))) {
      stop(0, "the file does not start with the MCAP magic");
      return;
    }
    data_crc_ = crc32(kMagic);
    std::uint64_t position = kMagic.size();
    bool first = true;
    while (true) {
      if (position == size) {
        stop(position, result_.reached_data_end
                           ? "the file ends after the data end without a footer (truncated)"
                           : "the file ends without a data end record (truncated recording)");
        return;
      }
      if (size - position < kRecordPrefixSize) {
        stop(position,
             "truncated record prefix: " + std::to_string(size - position) + " bytes left of 9");
        return;
      }
      const Bytes prefix = read(position, kRecordPrefixSize);
      Cursor prefix_cursor(prefix, position, "record prefix");
      const std::uint8_t opcode = prefix_cursor.u8();
      const std::uint64_t length = prefix_cursor.u64();
      if (length > size - position - kRecordPrefixSize) {
        stop(position, opcode_text(opcode) + " claims " + std::to_string(length) +
                           " content bytes, only " +
                           std::to_string(size - position - kRecordPrefixSize) +
                           " remain (truncated or corrupt length)");
        return;
      }
      if (opcode == 0) {
        stop(position, "opcode 0 is not valid");
        return;
      }
      if (first && opcode != static_cast<std::uint8_t>(Opcode::kHeader)) {
        stop(position, "the first record is " + opcode_text(opcode) + ", not a header");
        return;
      }
      // Records after the data end (summary duplicates) need no content in memory.
      const bool skip_content =
          result_.reached_data_end && opcode != static_cast<std::uint8_t>(Opcode::kFooter);
      Bytes content = skip_content ? Bytes{} : read(position + kRecordPrefixSize, length);
      try {
        if (handle(opcode, content, position, prefix)) return;
      } catch (const Error& error) {
        stop(position, error.reason() + (error.offset() != position
                                             ? " (at byte " + std::to_string(error.offset()) + ")"
                                             : ""));
        return;
      }
      first = false;
      position += kRecordPrefixSize + length;
    }
  }

 private:
  Bytes read(std::uint64_t offset, std::uint64_t length) const {
    Bytes bytes(length);
    source_.read(offset, bytes);
    return bytes;
  }

  void stop(std::uint64_t offset, std::string reason) {
    result_.stopped_at = offset;
    result_.stop_reason = std::move(reason);
  }

  // True when the scan is finished.
  bool handle(std::uint8_t opcode, const Bytes& content, std::uint64_t offset,
              const Bytes& prefix) {
    const char* name = detail::opcode_name(opcode).data();
    Cursor in(content, offset + kRecordPrefixSize, name);
    const bool in_data = !result_.reached_data_end;
    switch (static_cast<Opcode>(opcode)) {
      case Opcode::kHeader:
        result_.header = detail::decode_header(in);
        break;
      case Opcode::kSchema:
        if (in_data) add_schema(detail::decode_schema(in));
        break;
      case Opcode::kChannel:
        if (in_data) add_channel(detail::decode_channel(in));
        break;
      case Opcode::kMessage:
        if (in_data) result_.messages.push_back(detail::decode_message(in));
        break;
      case Opcode::kChunk:
        if (in_data) read_chunk(in, offset);
        break;
      case Opcode::kAttachment:
        if (in_data) {
          result_.attachments.push_back(detail::decode_attachment(
              content, offset + kRecordPrefixSize, options_.validate_crcs));
        }
        break;
      case Opcode::kMetadata:
        if (in_data) result_.metadata.push_back(detail::decode_metadata(in));
        break;
      case Opcode::kDataEnd:
        if (in_data) {
          const std::uint32_t stored = detail::decode_data_end(in);
          if (options_.validate_crcs && stored != 0 && stored != data_crc_) {
            throw Error("data section CRC mismatch: stored " + std::to_string(stored) +
                            ", computed " + std::to_string(data_crc_),
                        offset);
          }
          result_.reached_data_end = true;
        }
        break;
      case Opcode::kFooter: {
        detail::decode_footer(in);
        const std::uint64_t magic_at = offset + kRecordPrefixSize + content.size();
        if (source_.size() - magic_at != kMagic.size() ||
            !is_magic(read(magic_at, kMagic.size()))) {
          throw Error("the footer is not followed by the closing magic and the end of the file",
                      magic_at);
        }
        result_.complete = true;
        return true;
      }
      default:
        break;  // message indexes, summary records and unknown opcodes carry no data to recover
    }
    if (in_data && !result_.reached_data_end) {
      data_crc_ = crc32(content, crc32(prefix, data_crc_));
    }
    return false;
  }

  void add_schema(Schema schema) {
    if (schema.id != 0) result_.schemas.insert_or_assign(schema.id, std::move(schema));
  }
  void add_channel(Channel channel) {
    result_.channels.insert_or_assign(channel.id, std::move(channel));
  }

  // All or nothing: a damaged chunk adds none of its messages, so what is recovered stays a
  // prefix of what was written.
  void read_chunk(Cursor& in, std::uint64_t offset) {
    const detail::ChunkFields chunk = detail::decode_chunk(in);
    const Bytes records = chunk_records(chunk, offset, options_);
    std::vector<Schema> schemas;
    std::vector<Channel> channels;
    std::vector<Message> messages;
    try {
      std::uint64_t position = 0;
      while (position < records.size()) {
        const RecordView record = next_record(records, position, 0, "chunk records");
        Cursor inner(record.content, record.offset + kRecordPrefixSize,
                     detail::opcode_name(record.opcode));
        switch (static_cast<Opcode>(record.opcode)) {
          case Opcode::kSchema:
            schemas.push_back(detail::decode_schema(inner));
            break;
          case Opcode::kChannel:
            channels.push_back(detail::decode_channel(inner));
            break;
          case Opcode::kMessage:
            messages.push_back(detail::decode_message(inner));
            break;
          default:
            break;  // only schema, channel and message records belong in chunks
        }
      }
    } catch (const Error& error) {
      rethrow_in_chunk(error, offset);
    }
    for (Schema& schema : schemas) add_schema(std::move(schema));
    for (Channel& channel : channels) add_channel(std::move(channel));
    for (Message& message : messages) result_.messages.push_back(std::move(message));
  }

  const ByteSource& source_;
  const ReaderOptions& options_;
  ScanResult& result_;
  std::uint32_t data_crc_ = 0;
};

}  // namespace

ScanResult scan(const ByteSource& source, const ReaderOptions& options) {
  ScanResult result;
  Scanner(source, options, result).run();
  return result;
}

ScanResult scan_file(const std::filesystem::path& path, const ReaderOptions& options) {
  return scan(FileSource(path), options);
}

// ---------------------------------------------------------------------------------------
// Indexed reader

struct Reader::PendingMessage {
  Message message;
  std::uint64_t chunk_offset = 0;
  std::uint64_t record_offset = 0;  // inside the chunk: keeps file order among equal times
};

Reader Reader::open(const std::filesystem::path& path, ReaderOptions options) {
  return Reader(std::make_unique<FileSource>(path), options);
}

Bytes Reader::read_range(std::uint64_t offset, std::uint64_t length, const char* what) const {
  const std::uint64_t size = source_->size();
  if (offset > size || length > size - offset) {
    throw Error(std::string(what) + " spans " + std::to_string(length) + " bytes from byte " +
                    std::to_string(offset) + ", past the end of the " + std::to_string(size) +
                    "-byte file",
                offset);
  }
  Bytes bytes(length);
  source_->read(offset, bytes);
  return bytes;
}

Reader::Reader(std::unique_ptr<ByteSource> source, ReaderOptions options)
    : source_(std::move(source)), options_(options) {
  const std::uint64_t size = source_->size();
  if (size < kMinimumFileSize) {
    throw Error("file of " + std::to_string(size) + " bytes is too short for an MCAP file (" +
                    std::to_string(kMinimumFileSize) + " at least)",
                0);
  }
  if (!is_magic(read_range(0, kMagic.size(), "leading magic"))) {
    throw Error("the file does not start with the MCAP magic", 0);
  }
  if (!is_magic(read_range(size - kMagic.size(), kMagic.size(), "trailing magic"))) {
    throw Error("the file does not end with the MCAP magic (truncated? use scan())",
                size - kMagic.size());
  }
  footer_offset_ = size - kMagic.size() - kFooterRecordSize;
  const Bytes footer = read_range(footer_offset_, kFooterRecordSize, "footer");
  Cursor footer_cursor(footer, footer_offset_, "footer");
  if (footer_cursor.u8() != static_cast<std::uint8_t>(Opcode::kFooter) ||
      footer_cursor.u64() != 20) {  // the footer is never extended: always 20 content bytes
    throw Error("no footer record before the trailing magic", footer_offset_);
  }
  footer_ = detail::decode_footer(footer_cursor);

  // Header: the first record, bounded by the footer.
  const Bytes header_prefix = read_range(kMagic.size(), kRecordPrefixSize, "header");
  Cursor header_cursor(header_prefix, kMagic.size(), "header");
  if (header_cursor.u8() != static_cast<std::uint8_t>(Opcode::kHeader)) {
    throw Error("the first record is not a header", kMagic.size());
  }
  const std::uint64_t header_length = header_cursor.u64();
  const std::uint64_t header_content_at = kMagic.size() + kRecordPrefixSize;
  if (header_length > footer_offset_ - header_content_at) {
    throw Error("header length " + std::to_string(header_length) + " runs past the footer",
                kMagic.size());
  }
  const Bytes header = read_range(header_content_at, header_length, "header");
  Cursor header_body(header, header_content_at, "header");
  header_ = detail::decode_header(header_body);
  const std::uint64_t data_start = header_content_at + header_length;

  if (footer_.summary_start == 0) {
    data_end_limit_ = footer_offset_;
    // No summary: learn schemas and channels from a scan, reads fall back to scanning.
    ScanResult scanned = scan(*source_, options_);
    if (!scanned.complete) throw Error(scanned.stop_reason, scanned.stopped_at);
    summary_.schemas = std::move(scanned.schemas);
    summary_.channels = std::move(scanned.channels);
    return;
  }
  if (footer_.summary_start < data_start || footer_.summary_start > footer_offset_) {
    throw Error("footer summary_start " + std::to_string(footer_.summary_start) +
                    " lies outside the file's records",
                footer_offset_);
  }
  if (footer_.summary_offset_start != 0 && (footer_.summary_offset_start < footer_.summary_start ||
                                            footer_.summary_offset_start > footer_offset_)) {
    throw Error("footer summary_offset_start " + std::to_string(footer_.summary_offset_start) +
                    " lies outside the summary",
                footer_offset_);
  }
  data_end_limit_ = footer_.summary_start;
  read_summary();
  indexed_ = !summary_.chunk_indexes.empty();
}

void Reader::read_summary() {
  const std::uint64_t start = footer_.summary_start;
  // Summary, summary offsets and the footer up to its CRC field: what summary_crc covers.
  const Bytes bytes = read_range(start, footer_offset_ + kRecordPrefixSize + 16 - start, "summary");
  if (options_.validate_crcs && footer_.summary_crc != 0) {
    const std::uint32_t actual = crc32(bytes);
    if (actual != footer_.summary_crc) {
      throw Error("summary CRC mismatch: stored " + std::to_string(footer_.summary_crc) +
                      ", computed " + std::to_string(actual),
                  start);
    }
  }
  const ByteView records = ByteView(bytes).first(footer_offset_ - start);
  std::uint64_t position = 0;
  while (position < records.size()) {
    const RecordView record = next_record(records, position, start, "summary");
    Cursor in(record.content, record.offset + kRecordPrefixSize,
              detail::opcode_name(record.opcode));
    switch (static_cast<Opcode>(record.opcode)) {
      case Opcode::kSchema: {
        Schema schema = detail::decode_schema(in);
        if (schema.id != 0) summary_.schemas.insert_or_assign(schema.id, std::move(schema));
        break;
      }
      case Opcode::kChannel: {
        Channel channel = detail::decode_channel(in);
        summary_.channels.insert_or_assign(channel.id, std::move(channel));
        break;
      }
      case Opcode::kStatistics:
        summary_.statistics = detail::decode_statistics(in);
        break;
      case Opcode::kChunkIndex:
        summary_.chunk_indexes.push_back(detail::decode_chunk_index(in));
        break;
      case Opcode::kAttachmentIndex:
        summary_.attachment_indexes.push_back(detail::decode_attachment_index(in));
        break;
      case Opcode::kMetadataIndex:
        summary_.metadata_indexes.push_back(detail::decode_metadata_index(in));
        break;
      case Opcode::kSummaryOffset:
        summary_.summary_offsets.push_back(detail::decode_summary_offset(in));
        break;
      default:
        break;  // unknown records are allowed and ignored
    }
  }
}

void Reader::read_chunk_messages(const ChunkIndex& index, const MessageFilter& filter,
                                 const std::map<std::uint16_t, bool>& wanted,
                                 std::vector<PendingMessage>& out) const {
  const std::uint64_t chunk_offset = index.chunk_start_offset;
  if (chunk_offset < kMagic.size() || chunk_offset > data_end_limit_ ||
      index.chunk_length > data_end_limit_ - chunk_offset ||
      index.chunk_length < kRecordPrefixSize) {
    throw Error("chunk index points at " + std::to_string(index.chunk_length) +
                    " bytes from byte " + std::to_string(chunk_offset) +
                    ", outside the data section",
                chunk_offset);
  }
  const Bytes chunk_bytes = read_range(chunk_offset, index.chunk_length, "chunk");
  std::uint64_t position = 0;
  const RecordView record = next_record(chunk_bytes, position, chunk_offset, "chunk");
  if (record.opcode != static_cast<std::uint8_t>(Opcode::kChunk) ||
      position != chunk_bytes.size()) {
    throw Error("chunk index points at " + opcode_text(record.opcode) + " of " +
                    std::to_string(position) + " bytes, not a chunk of " +
                    std::to_string(index.chunk_length),
                chunk_offset);
  }
  Cursor in(record.content, chunk_offset + kRecordPrefixSize, "chunk");
  const detail::ChunkFields chunk = detail::decode_chunk(in);
  const Bytes records = chunk_records(chunk, chunk_offset, options_);
  ++chunks_read_;

  auto take = [&](Message message, std::uint64_t record_offset) {
    const auto it = wanted.find(message.channel_id);
    if (it == wanted.end()) {
      throw Error("message on channel " + std::to_string(message.channel_id) +
                      " that the summary does not list",
                  chunk_offset);
    }
    if (!it->second || message.log_time < filter.start_time || message.log_time > filter.end_time) {
      return;
    }
    out.push_back({std::move(message), chunk_offset, record_offset});
  };
  auto message_at = [&](std::uint64_t record_offset) {
    try {
      std::uint64_t inner = record_offset;
      if (record_offset > records.size()) {
        throw Error("message index offset lies past the chunk's records", record_offset);
      }
      const RecordView message_record = next_record(records, inner, 0, "chunk records");
      if (message_record.opcode != static_cast<std::uint8_t>(Opcode::kMessage)) {
        throw Error("message index points at " + opcode_text(message_record.opcode), record_offset);
      }
      Cursor message_cursor(message_record.content, record_offset + kRecordPrefixSize, "message");
      return detail::decode_message(message_cursor);
    } catch (const Error& error) {
      rethrow_in_chunk(error, chunk_offset);
    }
  };

  if (index.message_index_offsets.empty()) {
    // No message index: every record of the chunk is looked at.
    try {
      std::uint64_t inner = 0;
      while (inner < records.size()) {
        const RecordView inner_record = next_record(records, inner, 0, "chunk records");
        if (inner_record.opcode != static_cast<std::uint8_t>(Opcode::kMessage)) continue;
        Cursor message_cursor(inner_record.content, inner_record.offset + kRecordPrefixSize,
                              "message");
        take(detail::decode_message(message_cursor), inner_record.offset);
      }
    } catch (const Error& error) {
      rethrow_in_chunk(error, chunk_offset);
    }
    return;
  }

  // Message indexes follow the chunk; read only those of wanted channels.
  const std::uint64_t indexes_start = chunk_offset + index.chunk_length;
  if (index.message_index_length > data_end_limit_ - indexes_start) {
    throw Error("message indexes of the chunk run past the data section", indexes_start);
  }
  const Bytes index_bytes =
      read_range(indexes_start, index.message_index_length, "message indexes");
  for (const auto& [channel_id, index_offset] : index.message_index_offsets) {
    const auto it = wanted.find(channel_id);
    if (it != wanted.end() && !it->second) continue;
    if (index_offset < indexes_start || index_offset - indexes_start >= index_bytes.size()) {
      throw Error("message index of channel " + std::to_string(channel_id) + " at byte " +
                      std::to_string(index_offset) + " lies outside the chunk's index records",
                  indexes_start);
    }
    std::uint64_t index_position = index_offset - indexes_start;
    const RecordView index_record =
        next_record(index_bytes, index_position, indexes_start, "message index");
    if (index_record.opcode != static_cast<std::uint8_t>(Opcode::kMessageIndex)) {
      throw Error("expected a message index, found " + opcode_text(index_record.opcode),
                  index_offset);
    }
    Cursor index_cursor(index_record.content, index_offset + kRecordPrefixSize, "message index");
    const detail::MessageIndexFields fields = detail::decode_message_index(index_cursor);
    if (fields.channel_id != channel_id) {
      throw Error("message index is for channel " + std::to_string(fields.channel_id) +
                      ", the chunk index says " + std::to_string(channel_id),
                  index_offset);
    }
    for (const MessageIndexEntry& entry : fields.entries) {
      if (entry.log_time < filter.start_time || entry.log_time > filter.end_time) continue;
      Message message = message_at(entry.offset);
      if (message.channel_id != channel_id || message.log_time != entry.log_time) {
        throw Error("message index entry (channel " + std::to_string(channel_id) + ", time " +
                        std::to_string(entry.log_time) + ") does not match the message at " +
                        "uncompressed offset " + std::to_string(entry.offset),
                    index_offset);
      }
      take(std::move(message), entry.offset);
    }
  }
}

void Reader::for_each_message(const MessageFilter& filter, const MessageCallback& callback) const {
  chunks_read_ = 0;
  if (!indexed_) {
    scan_messages(filter, callback);
    return;
  }
  // Channel id -> wanted?
  std::map<std::uint16_t, bool> wanted;
  for (const auto& [id, channel] : summary_.channels) {
    wanted[id] = filter.topics.empty() || std::find(filter.topics.begin(), filter.topics.end(),
                                                    channel.topic) != filter.topics.end();
  }
  std::vector<const ChunkIndex*> chunks;
  for (const ChunkIndex& index : summary_.chunk_indexes) {
    if (index.message_end_time < filter.start_time || index.message_start_time > filter.end_time) {
      continue;
    }
    bool has_wanted = index.message_index_offsets.empty();  // unknown: must look inside
    for (const auto& [channel_id, offset] : index.message_index_offsets) {
      const auto it = wanted.find(channel_id);
      has_wanted = has_wanted || it == wanted.end() || it->second;
    }
    if (has_wanted) chunks.push_back(&index);
  }
  std::sort(chunks.begin(), chunks.end(), [](const ChunkIndex* a, const ChunkIndex* b) {
    return std::tie(a->message_start_time, a->chunk_start_offset) <
           std::tie(b->message_start_time, b->chunk_start_offset);
  });

  // Chunks may overlap in time: messages wait in `pending` until no later chunk can hold an
  // earlier one, i.e. until their time is below the next chunk's start.
  auto order = [](const PendingMessage& a, const PendingMessage& b) {
    return std::tie(a.message.log_time, a.chunk_offset, a.record_offset) <
           std::tie(b.message.log_time, b.chunk_offset, b.record_offset);
  };
  std::vector<PendingMessage> pending;
  auto emit_before = [&](Timestamp limit, bool all) {
    std::sort(pending.begin(), pending.end(), order);
    std::size_t emitted = 0;
    for (; emitted < pending.size(); ++emitted) {
      const PendingMessage& next = pending[emitted];
      if (!all && next.message.log_time >= limit) break;
      callback(next.message, summary_.channels.at(next.message.channel_id));
    }
    pending.erase(pending.begin(), pending.begin() + static_cast<std::ptrdiff_t>(emitted));
  };
  for (const ChunkIndex* index : chunks) {
    emit_before(index->message_start_time, false);
    read_chunk_messages(*index, filter, wanted, pending);
  }
  emit_before(0, true);
}

void Reader::scan_messages(const MessageFilter& filter, const MessageCallback& callback) const {
  ScanResult scanned = scan(*source_, options_);
  if (!scanned.complete) throw Error(scanned.stop_reason, scanned.stopped_at);
  std::vector<Message*> selected;
  for (Message& message : scanned.messages) {
    const auto channel = scanned.channels.find(message.channel_id);
    if (channel == scanned.channels.end()) {
      throw Error("message on channel " + std::to_string(message.channel_id) +
                      " that no channel record defines",
                  0);
    }
    const bool topic_ok =
        filter.topics.empty() || std::find(filter.topics.begin(), filter.topics.end(),
                                           channel->second.topic) != filter.topics.end();
    if (topic_ok && message.log_time >= filter.start_time && message.log_time <= filter.end_time) {
      selected.push_back(&message);
    }
  }
  std::stable_sort(selected.begin(), selected.end(),
                   [](const Message* a, const Message* b) { return a->log_time < b->log_time; });
  for (const Message* message : selected) {
    callback(*message, scanned.channels.at(message->channel_id));
  }
}

std::vector<Message> Reader::read_messages(const MessageFilter& filter) const {
  std::vector<Message> messages;
  for_each_message(filter,
                   [&](const Message& message, const Channel&) { messages.push_back(message); });
  return messages;
}

Attachment Reader::read_attachment(const AttachmentIndex& index) const {
  if (index.offset > data_end_limit_ || index.length > data_end_limit_ - index.offset) {
    throw Error("attachment index points outside the data section", index.offset);
  }
  const Bytes bytes = read_range(index.offset, index.length, "attachment");
  std::uint64_t position = 0;
  const RecordView record = next_record(bytes, position, index.offset, "attachment");
  if (record.opcode != static_cast<std::uint8_t>(Opcode::kAttachment)) {
    throw Error("attachment index points at " + opcode_text(record.opcode), index.offset);
  }
  return detail::decode_attachment(record.content, index.offset + kRecordPrefixSize,
                                   options_.validate_crcs);
}

Metadata Reader::read_metadata(const MetadataIndex& index) const {
  if (index.offset > data_end_limit_ || index.length > data_end_limit_ - index.offset) {
    throw Error("metadata index points outside the data section", index.offset);
  }
  const Bytes bytes = read_range(index.offset, index.length, "metadata");
  std::uint64_t position = 0;
  const RecordView record = next_record(bytes, position, index.offset, "metadata");
  if (record.opcode != static_cast<std::uint8_t>(Opcode::kMetadata)) {
    throw Error("metadata index points at " + opcode_text(record.opcode), index.offset);
  }
  Cursor in(record.content, index.offset + kRecordPrefixSize, "metadata");
  return detail::decode_metadata(in);
}

void Reader::verify_data_section_crc() const {
  ReaderOptions options = options_;
  options.validate_crcs = true;
  const ScanResult scanned = scan(*source_, options);
  if (!scanned.complete) throw Error(scanned.stop_reason, scanned.stopped_at);
}

}  // namespace fl::mcap
