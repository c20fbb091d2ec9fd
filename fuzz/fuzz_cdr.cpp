// The XCDR1 decoder of recordings (vision/record cdr.hpp), for every type a recording
// carries. A decode either returns a sample or throws CdrError; anything else (a crash, an
// out-of-bounds read, another exception) is a finding. A decoded sample must also survive
// the round trip: encoding it and decoding that again gives the same bytes once more.
#include <cstdint>
#include <cstdlib>

#include "fl/vision/record/cdr.hpp"
#include "fuzz_input.hpp"

namespace {

using fl::fuzz::CdrType;
namespace record = fl::vision::record;

// encode(decode(bytes)) is canonical: decoding and encoding it again must not change it.
template <typename Decode>
void check_round_trip(record::ByteView bytes, Decode decode) {
  const record::Bytes first = record::encode(decode(bytes));
  const record::Bytes second = record::encode(decode(first));
  if (first != second) std::abort();
}

void decode(CdrType type, record::ByteView bytes) {
  switch (type) {
    case CdrType::kCameraEstimates:
      check_round_trip(bytes, record::decode_camera_estimates);
      break;
    case CdrType::kLineCommand:
      check_round_trip(bytes, record::decode_line_command);
      break;
    case CdrType::kLineStatus:
      check_round_trip(bytes, record::decode_line_status);
      break;
    case CdrType::kDriveFeedback:
      check_round_trip(bytes, record::decode_drive_feedback);
      break;
    case CdrType::kLineSensors:
      check_round_trip(bytes, record::decode_line_sensors);
      break;
    case CdrType::kCompressedImage:
      check_round_trip(bytes, record::decode_compressed_image);
      break;
    case CdrType::kCount:
      break;
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fl::fuzz::FuzzInput input(data, size);
  const auto type = static_cast<CdrType>(input.u8() % fl::fuzz::kCdrTypeCount);
  try {
    decode(type, input.rest());
  } catch (const record::CdrError&) {
    // The documented refusal of a malformed sample.
  }
  return 0;
}
