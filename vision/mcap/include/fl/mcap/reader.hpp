#pragma once
// Reads MCAP files. Reader opens a complete file (magic at both ends, footer, summary) and
// serves messages by time range and topic through the chunk and message indexes, reading
// only the chunks that can hold a match. scan() walks a file front to back instead: it is
// the fallback for files without a summary and the recovery path for truncated recordings.
// Every malformed input throws fl::mcap::Error with the byte offset; no length field is
// trusted before it has been checked against the bytes that are really there.

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fl/mcap/records.hpp"

namespace fl::mcap {

// Random access to the file's bytes.
class ByteSource {
 public:
  virtual ~ByteSource() = default;
  virtual std::uint64_t size() const = 0;
  // Fills `out` from `offset`; callers keep offset + out.size() <= size().
  virtual void read(std::uint64_t offset, std::span<std::uint8_t> out) const = 0;
};

class FileSource final : public ByteSource {
 public:
  explicit FileSource(const std::filesystem::path& path);  // throws std::runtime_error
  std::uint64_t size() const override { return size_; }
  void read(std::uint64_t offset, std::span<std::uint8_t> out) const override;

 private:
  mutable std::ifstream file_;
  std::uint64_t size_ = 0;
};

class MemorySource final : public ByteSource {
 public:
  explicit MemorySource(Bytes bytes) : bytes_(std::move(bytes)) {}
  std::uint64_t size() const override { return bytes_.size(); }
  void read(std::uint64_t offset, std::span<std::uint8_t> out) const override;

 private:
  Bytes bytes_;
};

struct ReaderOptions {
  bool validate_crcs = true;  // chunk, attachment, summary and (in scan) data section CRCs
  // Largest chunk the reader will decompress; a corrupt size beyond it is an error rather
  // than an allocation. 1 GiB is far above any sensible chunk (writers use about 1 MiB).
  std::uint64_t max_chunk_bytes = std::uint64_t{1} << 30;
};

// Which messages to read. Times are log times; both ends are inclusive, as in @mcap/core.
struct MessageFilter {
  Timestamp start_time = 0;
  Timestamp end_time = std::numeric_limits<Timestamp>::max();
  std::vector<std::string> topics;  // empty: every topic
};

struct Summary {
  std::map<std::uint16_t, Schema> schemas;
  std::map<std::uint16_t, Channel> channels;
  std::optional<Statistics> statistics;
  std::vector<ChunkIndex> chunk_indexes;
  std::vector<AttachmentIndex> attachment_indexes;
  std::vector<MetadataIndex> metadata_indexes;
  std::vector<SummaryOffset> summary_offsets;
};

// What a front-to-back scan found, and where and why it stopped.
struct ScanResult {
  Header header;
  std::map<std::uint16_t, Schema> schemas;
  std::map<std::uint16_t, Channel> channels;
  std::vector<Message> messages;  // file order; a chunk counts only when all of it is sound
  std::vector<Attachment> attachments;
  std::vector<Metadata> metadata;
  bool reached_data_end = false;
  bool complete = false;         // data end, footer and trailing magic all present and sound
  std::uint64_t stopped_at = 0;  // byte offset of the first record that could not be used
  std::string stop_reason;       // empty when complete
};

ScanResult scan(const ByteSource& source, const ReaderOptions& options = {});
ScanResult scan_file(const std::filesystem::path& path, const ReaderOptions& options = {});

using MessageCallback = std::function<void(const Message& message, const Channel& channel)>;

class Reader {
 public:
  // Checks both magics, the header, the footer and the summary (and its CRC).
  explicit Reader(std::unique_ptr<ByteSource> source, ReaderOptions options = {});
  static Reader open(const std::filesystem::path& path, ReaderOptions options = {});

  const Header& header() const { return header_; }
  const Footer& footer() const { return footer_; }
  // True when the file carries a summary with chunk indexes, so reads use the index.
  bool indexed() const { return indexed_; }
  // The summary section; for a file without one, what a scan found (schemas, channels).
  const Summary& summary() const { return summary_; }

  // Matching messages in log-time order (ties in file order).
  void for_each_message(const MessageFilter& filter, const MessageCallback& callback) const;
  std::vector<Message> read_messages(const MessageFilter& filter = {}) const;

  Attachment read_attachment(const AttachmentIndex& index) const;
  Metadata read_metadata(const MetadataIndex& index) const;
  // Reads the whole data section and compares it with the data end CRC (0: not recorded).
  void verify_data_section_crc() const;

  // How many chunk records the last for_each_message decompressed (shows index use).
  std::uint64_t chunks_read_last_call() const { return chunks_read_; }

 private:
  struct PendingMessage;
  Bytes read_range(std::uint64_t offset, std::uint64_t length, const char* what) const;
  void read_summary();
  void read_chunk_messages(const ChunkIndex& index, const MessageFilter& filter,
                           const std::map<std::uint16_t, bool>& wanted,
                           std::vector<PendingMessage>& out) const;
  void scan_messages(const MessageFilter& filter, const MessageCallback& callback) const;

  std::unique_ptr<ByteSource> source_;
  ReaderOptions options_;
  Header header_;
  Footer footer_;
  std::uint64_t footer_offset_ = 0;
  std::uint64_t data_end_limit_ = 0;  // data records lie before this offset
  bool indexed_ = false;
  Summary summary_;
  mutable std::uint64_t chunks_read_ = 0;
};

}  // namespace fl::mcap
