#include "fl/mcap/writer.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <limits>
#include <stdexcept>

#include "codec.hpp"

namespace fl::mcap {

using detail::ByteWriter;

namespace {

// The system's reason for the last failed stream operation ("No space left on device"):
// what an operator needs to act on a full disk. The streams keep errno from the write(2).
std::string system_reason() {
  const int error = errno;
  return error != 0 ? std::string(": ") + std::strerror(error) : std::string();
}

std::unique_ptr<std::ofstream> open_for_writing(const std::filesystem::path& path) {
  errno = 0;
  auto file = std::make_unique<std::ofstream>(path, std::ios::binary | std::ios::trunc);
  if (!*file) throw std::runtime_error("mcap: cannot create " + path.string() + system_reason());
  return file;
}

}  // namespace

Writer::Writer(std::ostream& out, WriterOptions options)
    : out_(out), options_(std::move(options)), where_("mcap") {
  write_start();
}

Writer::Writer(const std::filesystem::path& path, WriterOptions options)
    : Writer(open_for_writing(path), std::move(options), path) {}

Writer::Writer(std::unique_ptr<std::ofstream> file, WriterOptions options,
               const std::filesystem::path& path)
    : owned_file_(std::move(file)),
      out_(*owned_file_),
      options_(std::move(options)),
      where_("mcap: " + path.string()) {
  if (options_.sync_chunks) {
    // fdatasync works on the file, whichever descriptor wrote it; the stream keeps its own.
    errno = 0;
    sync_fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (sync_fd_ < 0) {
      throw std::runtime_error(where_ + ": cannot open it for fdatasync" + system_reason());
    }
  }
  write_start();
}

void Writer::sync_to_disk() {
  if (sync_fd_ < 0) return;
  errno = 0;
  if (::fdatasync(sync_fd_) != 0) {
    throw std::runtime_error(where_ + ": fdatasync failed at byte " + std::to_string(position_) +
                             system_reason());
  }
}

void Writer::write_start() {
  write_bytes(kMagic);
  scratch_.clear();
  ByteWriter body(scratch_);
  detail::encode(body, Header{options_.profile, options_.library});
  write_record(Opcode::kHeader, scratch_);
}

Writer::~Writer() {
  try {
    close();
  } catch (...) {  // NOLINT(bugprone-empty-catch): destructors must not throw
  }
  if (sync_fd_ >= 0) ::close(sync_fd_);  // close() threw before it got there
}

void Writer::write_bytes(ByteView bytes) {
  // A stream that failed once (disk full) stays failed: every later record is refused too,
  // and what reached the file before stays a readable prefix (scan() recovers it).
  errno = 0;
  out_.write(reinterpret_cast<const char*>(bytes.data()),
             static_cast<std::streamsize>(bytes.size()));
  if (!out_) {
    throw std::runtime_error(where_ + ": write failed at byte " + std::to_string(position_) +
                             system_reason());
  }
  if (in_data_section_) data_crc_ = crc32(bytes, data_crc_);
  position_ += bytes.size();
}

void Writer::write_record(Opcode opcode, ByteView content) {
  Bytes prefix;
  ByteWriter writer(prefix);
  writer.u8(static_cast<std::uint8_t>(opcode));
  writer.u64(content.size());
  write_bytes(prefix);
  write_bytes(content);
}

std::uint16_t Writer::add_schema(std::string name, std::string encoding, ByteView data) {
  if (closed_) throw std::logic_error("mcap: add_schema after close");
  if (schemas_.size() >= std::numeric_limits<std::uint16_t>::max()) {
    throw std::length_error("mcap: too many schemas for uint16 ids");
  }
  Schema schema{static_cast<std::uint16_t>(schemas_.size() + 1), std::move(name),
                std::move(encoding), Bytes(data.begin(), data.end())};
  // Written straight into the data section so a reader of a truncated file meets it before
  // any chunk that uses it.
  scratch_.clear();
  ByteWriter body(scratch_);
  detail::encode(body, schema);
  write_record(Opcode::kSchema, scratch_);
  schemas_.push_back(std::move(schema));
  statistics_.schema_count = static_cast<std::uint16_t>(schemas_.size());
  return schemas_.back().id;
}

std::uint16_t Writer::add_channel(std::uint16_t schema_id, std::string topic,
                                  std::string message_encoding,
                                  std::map<std::string, std::string> metadata) {
  if (closed_) throw std::logic_error("mcap: add_channel after close");
  if (schema_id > schemas_.size()) {
    throw std::invalid_argument("mcap: channel '" + topic + "' names unknown schema " +
                                std::to_string(schema_id));
  }
  // Channel id 0 is valid in MCAP, but counting from 1 like schemas avoids confusion.
  if (channels_.size() + 1 >= std::numeric_limits<std::uint16_t>::max()) {
    throw std::length_error("mcap: too many channels for uint16 ids");
  }
  Channel channel{static_cast<std::uint16_t>(channels_.size() + 1), schema_id, std::move(topic),
                  std::move(message_encoding), std::move(metadata)};
  scratch_.clear();
  ByteWriter body(scratch_);
  detail::encode(body, channel);
  write_record(Opcode::kChannel, scratch_);
  channels_.push_back(std::move(channel));
  statistics_.channel_count = static_cast<std::uint32_t>(channels_.size());
  return channels_.back().id;
}

void Writer::write_message(const MessageToWrite& message) {
  if (closed_) throw std::logic_error("mcap: write_message after close");
  if (message.channel_id == 0 || message.channel_id > channels_.size()) {
    throw std::invalid_argument("mcap: message on unknown channel " +
                                std::to_string(message.channel_id));
  }
  if (statistics_.message_count == 0) {
    statistics_.message_start_time = message.log_time;
    statistics_.message_end_time = message.log_time;
  }
  statistics_.message_start_time = std::min(statistics_.message_start_time, message.log_time);
  statistics_.message_end_time = std::max(statistics_.message_end_time, message.log_time);
  ++statistics_.message_count;
  ++statistics_.channel_message_counts[message.channel_id];

  scratch_.clear();
  ByteWriter body(scratch_);
  detail::encode_message(body, message.channel_id, message.sequence, message.log_time,
                         message.publish_time, message.data);
  if (!options_.use_chunks) {
    write_record(Opcode::kMessage, scratch_);
    return;
  }
  if (!chunk_has_messages_) {
    chunk_start_time_ = message.log_time;
    chunk_end_time_ = message.log_time;
    chunk_has_messages_ = true;
  }
  chunk_start_time_ = std::min(chunk_start_time_, message.log_time);
  chunk_end_time_ = std::max(chunk_end_time_, message.log_time);
  chunk_message_index_[message.channel_id].push_back({message.log_time, chunk_records_.size()});
  detail::append_record(chunk_records_, Opcode::kMessage, scratch_);
  if (chunk_records_.size() >= options_.chunk_size) flush_chunk();
}

void Writer::flush_chunk() {
  if (chunk_records_.empty()) return;
  const Bytes compressed =
      detail::compress(options_.compression, chunk_records_, options_.zstd_level);
  ChunkIndex index;
  index.message_start_time = chunk_start_time_;
  index.message_end_time = chunk_end_time_;
  index.chunk_start_offset = position_;
  index.compression = std::string(compression_name(options_.compression));
  index.compressed_size = compressed.size();
  index.uncompressed_size = chunk_records_.size();

  Bytes body;
  ByteWriter chunk(body);
  chunk.u64(chunk_start_time_);
  chunk.u64(chunk_end_time_);
  chunk.u64(chunk_records_.size());
  chunk.u32(crc32(chunk_records_));
  chunk.string(index.compression);
  chunk.bytes64(compressed);
  write_record(Opcode::kChunk, body);
  index.chunk_length = position_ - index.chunk_start_offset;

  const std::uint64_t message_index_start = position_;
  for (const auto& [channel_id, entries] : chunk_message_index_) {
    index.message_index_offsets[channel_id] = position_;
    scratch_.clear();
    ByteWriter message_index(scratch_);
    message_index.u16(channel_id);
    message_index.u32(static_cast<std::uint32_t>(entries.size() * 16));  // 16 bytes per tuple
    for (const MessageIndexEntry& entry : entries) {
      message_index.u64(entry.log_time);
      message_index.u64(entry.offset);
    }
    write_record(Opcode::kMessageIndex, scratch_);
  }
  index.message_index_length = position_ - message_index_start;
  chunk_indexes_.push_back(std::move(index));
  ++statistics_.chunk_count;
  // Hand the whole chunk to the file system now, not when the stream's buffer happens to
  // fill: a recorder that dies (power loss, kill) loses at most the open chunk, and a full
  // disk is reported at the chunk that did not fit.
  errno = 0;
  out_.flush();
  if (!out_) {
    throw std::runtime_error(where_ + ": flush failed at byte " + std::to_string(position_) +
                             system_reason());
  }
  sync_to_disk();

  chunk_records_.clear();
  chunk_message_index_.clear();
  chunk_has_messages_ = false;
  chunk_start_time_ = 0;
  chunk_end_time_ = 0;
}

void Writer::write_attachment(const Attachment& attachment) {
  if (closed_) throw std::logic_error("mcap: write_attachment after close");
  scratch_.clear();
  ByteWriter body(scratch_);
  detail::encode_attachment(body, attachment);
  AttachmentIndex index{position_,
                        0,
                        attachment.log_time,
                        attachment.create_time,
                        attachment.data.size(),
                        attachment.name,
                        attachment.media_type};
  write_record(Opcode::kAttachment, scratch_);
  index.length = position_ - index.offset;
  attachment_indexes_.push_back(std::move(index));
  ++statistics_.attachment_count;
}

void Writer::write_metadata(const Metadata& metadata) {
  if (closed_) throw std::logic_error("mcap: write_metadata after close");
  scratch_.clear();
  ByteWriter body(scratch_);
  detail::encode(body, metadata);
  MetadataIndex index{position_, 0, metadata.name};
  write_record(Opcode::kMetadata, scratch_);
  index.length = position_ - index.offset;
  metadata_indexes_.push_back(std::move(index));
  ++statistics_.metadata_count;
}

void Writer::close() {
  if (closed_) return;
  closed_ = true;
  flush_chunk();
  Bytes body;
  ByteWriter data_end(body);
  data_end.u32(data_crc_);
  in_data_section_ = false;
  write_record(Opcode::kDataEnd, body);
  if (options_.write_summary) {
    write_summary();
  } else {
    body.clear();
    ByteWriter footer(body);
    detail::encode(footer, Footer{});
    write_record(Opcode::kFooter, body);
  }
  write_bytes(kMagic);
  errno = 0;
  out_.flush();
  if (!out_) throw std::runtime_error(where_ + ": flush failed" + system_reason());
  sync_to_disk();
  if (sync_fd_ >= 0) {
    ::close(sync_fd_);
    sync_fd_ = -1;
  }
  if (owned_file_) {
    owned_file_->close();
    if (!*owned_file_) {
      throw std::runtime_error(where_ + ": closing the file failed" + system_reason());
    }
  }
}

// The summary is buffered whole so that its CRC and the group offsets come out in one pass.
void Writer::write_summary() {
  const std::uint64_t summary_start = position_;
  Bytes summary;
  std::vector<SummaryOffset> offsets;
  auto add_group = [&](Opcode opcode, auto&& encode_each, std::size_t count) {
    if (count == 0) return;
    const std::uint64_t group_start = summary_start + summary.size();
    Bytes body;
    for (std::size_t index = 0; index < count; ++index) {
      body.clear();
      ByteWriter writer(body);
      encode_each(writer, index);
      detail::append_record(summary, opcode, body);
    }
    offsets.push_back({opcode, group_start, summary_start + summary.size() - group_start});
  };
  add_group(
      Opcode::kSchema, [&](ByteWriter& out, std::size_t i) { detail::encode(out, schemas_[i]); },
      schemas_.size());
  add_group(
      Opcode::kChannel, [&](ByteWriter& out, std::size_t i) { detail::encode(out, channels_[i]); },
      channels_.size());
  add_group(
      Opcode::kStatistics, [&](ByteWriter& out, std::size_t) { detail::encode(out, statistics_); },
      1);
  add_group(
      Opcode::kChunkIndex,
      [&](ByteWriter& out, std::size_t i) { detail::encode(out, chunk_indexes_[i]); },
      chunk_indexes_.size());
  add_group(
      Opcode::kAttachmentIndex,
      [&](ByteWriter& out, std::size_t i) { detail::encode(out, attachment_indexes_[i]); },
      attachment_indexes_.size());
  add_group(
      Opcode::kMetadataIndex,
      [&](ByteWriter& out, std::size_t i) { detail::encode(out, metadata_indexes_[i]); },
      metadata_indexes_.size());

  const std::uint64_t summary_offset_start = summary_start + summary.size();
  Bytes body;
  for (const SummaryOffset& offset : offsets) {
    body.clear();
    ByteWriter writer(body);
    detail::encode(writer, offset);
    detail::append_record(summary, Opcode::kSummaryOffset, body);
  }
  // The footer's CRC covers the summary, the offsets and the footer up to summary_crc.
  Bytes footer;
  ByteWriter footer_writer(footer);
  footer_writer.u8(static_cast<std::uint8_t>(Opcode::kFooter));
  footer_writer.u64(20);  // summary_start, summary_offset_start (8 + 8) and summary_crc (4)
  footer_writer.u64(summary_start);
  footer_writer.u64(summary_offset_start);
  const std::uint32_t summary_crc = crc32(footer, crc32(summary));
  footer_writer.u32(summary_crc);
  write_bytes(summary);
  write_bytes(footer);
}

}  // namespace fl::mcap
