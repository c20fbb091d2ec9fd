// MCAP files into the reader (vision/mcap): the indexed Reader (magics, footer, summary,
// then every message through the chunk indexes, every attachment and metadata record, the
// data section CRC) and the front-to-back scan() that recovers truncated recordings. The
// contract: results or fl::mcap::Error; anything else is a finding. A flags byte before the
// file switches CRC validation, so that the fuzzer also reaches what lies behind a CRC.
#include <cstdint>
#include <memory>

#include "fl/mcap/reader.hpp"
#include "fuzz_input.hpp"

namespace {

namespace mcap = fl::mcap;

// The reader refuses chunks above this before allocating; the default (1 GiB) is for real
// recordings, a smaller one keeps the fuzzer fast and still checks that the limit holds.
constexpr std::uint64_t kMaxChunkBytes = std::uint64_t{16} << 20U;

volatile std::size_t g_sink = 0;

void read_indexed(const mcap::Bytes& file, const mcap::ReaderOptions& options) {
  const mcap::Reader reader(std::make_unique<mcap::MemorySource>(file), options);
  const mcap::Summary& summary = reader.summary();
  for (const mcap::Message& message : reader.read_messages()) {
    g_sink = g_sink + message.data.size();
  }
  // A filtered read takes the index path that skips chunks.
  mcap::MessageFilter filter;
  for (const auto& [id, channel] : summary.channels) {
    filter.topics.push_back(channel.topic);
    break;
  }
  if (summary.statistics) {
    filter.start_time = summary.statistics->message_start_time;
    filter.end_time = summary.statistics->message_end_time;
  }
  reader.for_each_message(filter, [](const mcap::Message& message, const mcap::Channel& channel) {
    g_sink = g_sink + message.data.size() + channel.topic.size();
  });
  for (const mcap::AttachmentIndex& index : summary.attachment_indexes) {
    g_sink = g_sink + reader.read_attachment(index).data.size();
  }
  for (const mcap::MetadataIndex& index : summary.metadata_indexes) {
    g_sink = g_sink + reader.read_metadata(index).metadata.size();
  }
  reader.verify_data_section_crc();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fl::fuzz::FuzzInput input(data, size);
  mcap::ReaderOptions options;
  options.validate_crcs = (input.u8() & fl::fuzz::kMcapValidateCrcs) != 0U;
  options.max_chunk_bytes = kMaxChunkBytes;
  const auto rest = input.rest();
  const mcap::Bytes file(rest.begin(), rest.end());

  try {
    const mcap::ScanResult result = mcap::scan(mcap::MemorySource(file), options);
    g_sink = g_sink + result.messages.size() + result.stop_reason.size();
  } catch (const mcap::Error&) {
    // scan() stops at a bad record and reports it; throwing is allowed too.
  }
  try {
    read_indexed(file, options);
  } catch (const mcap::Error&) {
  }
  return 0;
}
