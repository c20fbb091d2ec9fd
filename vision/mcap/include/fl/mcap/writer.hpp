#pragma once
// Writes MCAP files: messages go into (optionally compressed) chunks, each followed by its
// message indexes and flushed to the file; close() adds the data end, the summary (schemas,
// channels, statistics, chunk/attachment/metadata indexes), the summary offsets and the footer.
// A writer that dies before close() leaves every flushed chunk readable by scan(): it loses at
// most the open chunk (WriterOptions::chunk_size of records) and what the operating system had
// not yet written back.

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <ostream>
#include <string>
#include <vector>

#include "fl/mcap/records.hpp"

namespace fl::mcap {

struct WriterOptions {
  std::string profile;  // e.g. "ros2"; empty for none
  std::string library = "fl_mcap";
  Compression compression = Compression::kZstd;
  int zstd_level = 3;  // zstd's own default: fast enough for live camera streams
  // A chunk is closed once its uncompressed records reach this size. 1 MiB keeps random
  // access cheap while compressing well (the reference writers use a similar default).
  std::uint64_t chunk_size = std::uint64_t{1024} * 1024;
  bool use_chunks = true;     // false: messages go straight into the data section, unindexed
  bool write_summary = true;  // false: the footer points at no summary (readers must scan)
  // Writers on a file: fdatasync after each closed chunk and at close, so that a power loss
  // keeps every closed chunk, not only what the kernel happened to write back. Costs a disk
  // round trip per chunk (milliseconds), off any real-time thread.
  bool sync_chunks = false;
};

struct MessageToWrite {
  std::uint16_t channel_id = 0;
  std::uint32_t sequence = 0;
  Timestamp log_time = 0;
  Timestamp publish_time = 0;
  ByteView data;
};

class Writer {
 public:
  // Writes into `out`, which must outlive the writer.
  Writer(std::ostream& out, WriterOptions options);
  // Creates (truncates) the file at `path`; throws std::runtime_error if it cannot. Every
  // error of a writer made this way names the file and the system's reason.
  Writer(const std::filesystem::path& path, WriterOptions options);
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;
  // Closes if close() was not called; errors are swallowed here, so call close() to see them.
  ~Writer();

  // Ids count from 1 (schema id 0 means "no schema").
  std::uint16_t add_schema(std::string name, std::string encoding, ByteView data);
  std::uint16_t add_channel(std::uint16_t schema_id, std::string topic,
                            std::string message_encoding,
                            std::map<std::string, std::string> metadata = {});
  void write_message(const MessageToWrite& message);
  void write_attachment(const Attachment& attachment);
  void write_metadata(const Metadata& metadata);
  // Flushes the open chunk and writes the data end, summary and footer. Idempotent.
  void close();

  std::uint64_t bytes_written() const { return position_; }
  const Statistics& statistics() const { return statistics_; }

 private:
  Writer(std::unique_ptr<std::ofstream> file, WriterOptions options,
         const std::filesystem::path& path);
  void write_start();
  void write_bytes(ByteView bytes);
  void write_record(Opcode opcode, ByteView content);
  void flush_chunk();
  void write_summary();
  void sync_to_disk();

  std::unique_ptr<std::ofstream> owned_file_;
  std::ostream& out_;
  WriterOptions options_;
  std::string where_;  // "mcap: <path>" for a file, "mcap" for a stream: the errors' prefix
  int sync_fd_ = -1;   // the file, opened again for fdatasync (sync_chunks)
  bool closed_ = false;
  std::uint64_t position_ = 0;
  std::uint32_t data_crc_ = 0;  // over every byte before the data end record
  bool in_data_section_ = true;

  std::vector<Schema> schemas_;
  std::vector<Channel> channels_;
  Statistics statistics_;
  std::vector<ChunkIndex> chunk_indexes_;
  std::vector<AttachmentIndex> attachment_indexes_;
  std::vector<MetadataIndex> metadata_indexes_;

  // The open chunk: uncompressed records, time range and per-channel message index.
  Bytes chunk_records_;
  Timestamp chunk_start_time_ = 0;
  Timestamp chunk_end_time_ = 0;
  bool chunk_has_messages_ = false;
  std::map<std::uint16_t, std::vector<MessageIndexEntry>> chunk_message_index_;
  Bytes scratch_;  // reused record body buffer
};

}  // namespace fl::mcap
