// Replay of a recording through the vision and the controller logic, in simulated time, and
// the golden result it is compared with (`linectl replay`, docs/vision.md).
//
// Replay: scan by scan, the input image is rebuilt from the recorded sensors and drive
// feedback; when a camera's recorded estimates arrive (their log time is the scan that
// received them), a camera with frames gets the estimator's result on the recorded frame with
// that sequence instead, a camera without frames the recorded estimates. LineController::update
// runs on that image. A recording without line state (real cameras only) replays the vision.
//
// Golden result: plain text, one block per entry, a person can read and diff it:
//   frame <camera> <sequence> t=<exposure s>       the estimator's view of one frame
//   scan <n> t=<s>                                 only scans whose outputs changed or that
//                                                  raised events or closed ledger records
//   end                                            the controller's counters at the end
// Entry lines are indented by two spaces; lines starting with '#' are comments.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "fl/controller/line_config.hpp"
#include "fl/vision/fillet_estimator.hpp"
#include "fl/vision/record/recording.hpp"

namespace fl::vision::record {

struct GoldenEntry {
  std::string header;  // "frame orientation 17 t=0.680000000": also the entry's key
  std::vector<std::string> lines;
  bool operator==(const GoldenEntry&) const = default;
};

struct ReplayOptions {
  EstimatorParams estimator;
  // The line configuration the controller runs with; empty: the recording's own (line.yaml
  // attachment).
  std::optional<LineConfig> line_config;
  // Threads that decode and measure frames ahead of the controller; 0: one per core. The
  // result does not depend on it.
  unsigned measure_threads = 0;
};

struct ReplayResult {
  std::vector<GoldenEntry> entries;
  std::uint64_t frames = 0;
  std::uint64_t scans = 0;
  // Frames whose replayed estimates differ from the estimates recorded with them (the
  // recording was made with another estimator or other parameters); informational.
  std::uint64_t frames_differing_from_recording = 0;
  // Scans whose replayed outputs differ from the command and status recorded with them, of
  // those that have them: 0 for a recording of this controller (linectl control --record,
  // or the twin's) replayed unchanged; informational.
  std::uint64_t scans_with_recorded_output = 0;
  std::uint64_t scans_differing_from_recording = 0;
  std::optional<std::uint64_t> first_scan_differing;
};

// Throws RecordingError for a recording that cannot be replayed (a frame that does not
// decode, estimates that name a frame not recorded, no line configuration).
ReplayResult replay(const Recording& recording, const ReplayOptions& options);

// Sets one estimator parameter by its EstimatorParams member name ("min_solidity=0.95");
// throws std::invalid_argument for an unknown name or a value that is not a finite number.
void set_estimator_param(EstimatorParams& params, std::string_view assignment);

std::string format_golden(const std::vector<GoldenEntry>& entries, std::string_view comment);
// Throws std::runtime_error naming the source and line for text that is not a golden file.
std::vector<GoldenEntry> parse_golden(std::string_view text, std::string_view source_name);

struct GoldenDifference {
  std::string header;
  std::optional<GoldenEntry> expected;  // empty: only in the replay
  std::optional<GoldenEntry> actual;    // empty: only in the golden
};
// Differences in the order the entries appear (golden order, replay-only entries after the
// golden entry they follow).
std::vector<GoldenDifference> compare_golden(const std::vector<GoldenEntry>& expected,
                                             const std::vector<GoldenEntry>& actual);
// "-" golden line, "+" replayed line, unchanged lines of a changed entry are left out.
std::string format_difference(const GoldenDifference& difference);

}  // namespace fl::vision::record
