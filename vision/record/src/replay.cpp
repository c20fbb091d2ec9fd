#include "fl/vision/record/replay.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <exception>
#include <limits>
#include <map>
#include <numbers>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <utility>

#include "fl/controller/config_loader.hpp"
#include "fl/controller/line_controller.hpp"

namespace fl::vision::record {
namespace {

constexpr double kDegPerRad = 180.0 / std::numbers::pi;

template <typename... Args>
std::string format(const char* pattern, Args... args) {
  char text[256];
  std::snprintf(text, sizeof text, pattern, args...);
  return text;
}

std::string time_s(std::int64_t ns) { return format("t=%.9f", static_cast<double>(ns) / 1e9); }

// printf's %s of a name from process_image.hpp (to_string's views are whole literals).
const char* name(std::string_view text) { return text.data(); }

std::string estimate_line(const FilletEstimate& e) {
  return format(
      "fillet x_mm=%.2f y_mm=%.2f angle_deg=%.2f confidence=%.3f hand=%s side=%s "
      "singulated=%d",
      static_cast<double>(e.x_mm), static_cast<double>(e.y_mm),
      static_cast<double>(e.angle_rad) * kDegPerRad, static_cast<double>(e.confidence),
      name(to_string(e.hand)), name(to_string(e.side)), e.singulated ? 1 : 0);
}

GoldenEntry frame_entry(CameraId camera, std::int64_t exposure_ns, const FrameResult& result) {
  GoldenEntry entry;
  entry.header = "frame " + std::string(camera_name(camera)) + " " +
                 std::to_string(result.sequence) + " " + time_s(exposure_ns);
  std::string status = "status " + std::string(to_string(result.status));
  if (result.status != FrameStatus::kOk) status += " (" + result.message + ")";
  entry.lines.push_back(status);
  for (const BlobResult& blob : result.blobs) {
    if (blob.status == BlobStatus::kFillet) {
      entry.lines.push_back(estimate_line(blob.estimate));
    } else {
      entry.lines.push_back(format("%s area_mm2=%.0f", std::string(to_string(blob.status)).c_str(),
                                   blob.features.area_mm2));
    }
  }
  return entry;
}

bool same_frame(const CameraFrame& a, const CameraFrame& b) {
  if (a.frame_time_ns != b.frame_time_ns || a.sequence != b.sequence || a.count != b.count) {
    return false;
  }
  for (std::size_t i = 0; i < a.count; ++i) {
    const FilletEstimate& x = a.estimates[i];
    const FilletEstimate& y = b.estimates[i];
    if (x.x_mm != y.x_mm || x.y_mm != y.y_mm || x.angle_rad != y.angle_rad ||
        x.confidence != y.confidence || x.hand != y.hand || x.side != y.side ||
        x.singulated != y.singulated) {
      return false;
    }
  }
  return true;
}

// The output image as (field, formatted value) pairs; a scan entry lists those that changed.
std::vector<std::pair<std::string, std::string>> output_fields(const OutputImage& out) {
  std::vector<std::pair<std::string, std::string>> fields;
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    const DriveCommand& drive = out.drives[d];
    fields.emplace_back(
        "drive." + std::string(to_string(static_cast<DriveId>(d))),
        format("enable=%d speed_mps=%.4f accel_mps2=%.3f", drive.enable ? 1 : 0,
               static_cast<double>(drive.speed_mps), static_cast<double>(drive.accel_mps2)));
  }
  fields.emplace_back("hopper_opening_mm",
                      format("%.2f", static_cast<double>(out.hopper_opening_mm)));
  fields.emplace_back("leveller_speed_rpm",
                      format("%.1f", static_cast<double>(out.leveller_speed_rpm)));
  fields.emplace_back("flip_plate1_flip", out.flip_plate1_flip ? "1" : "0");
  fields.emplace_back("flip_plate2_flip", out.flip_plate2_flip ? "1" : "0");
  fields.emplace_back("centring_shift_mm",
                      format("%.2f", static_cast<double>(out.centring_shift_mm)));
  fields.emplace_back("centring_stroke", out.centring_stroke ? "1" : "0");
  fields.emplace_back("squeeze_roller_down", out.squeeze_roller_down ? "1" : "0");
  fields.emplace_back("final_reject", out.final_reject ? "1" : "0");
  fields.emplace_back("state", std::string(to_string(out.state)));
  fields.emplace_back("active_faults", format("0x%08x", out.active_faults));
  return fields;
}

std::string event_line(const Event& event) {
  return format("event %s item=%u source=%u value=%.3f", to_string(event.code), event.item_id,
                static_cast<unsigned>(event.source), static_cast<double>(event.value));
}

std::string record_line(const FilletRecord& r) {
  return format(
      "ledger id=%u created_s=%.3f outcome=%s lost_reason=%s hand=%s side_seen=%s singulated=%d "
      "flip_plate1=%d flip_plate2=%d multilane_unit=%d angle_at_camera1_deg=%.2f "
      "final_angle_deg=%.2f final_y_mm=%.2f",
      r.id, static_cast<double>(r.created_ns) / 1e9, to_string(r.outcome), to_string(r.lost_reason),
      name(to_string(r.hand)), name(to_string(r.side_seen)), r.singulated ? 1 : 0,
      r.flip_plate1 ? 1 : 0, r.flip_plate2 ? 1 : 0, static_cast<int>(r.multilane_unit),
      static_cast<double>(r.angle_at_camera1_rad) * kDegPerRad,
      static_cast<double>(r.final_angle_rad) * kDegPerRad, static_cast<double>(r.final_y_mm));
}

GoldenEntry end_entry(const LineController& controller, std::int64_t time_ns) {
  GoldenEntry entry;
  entry.header = "end " + time_s(time_ns);
  const ControllerCounters& c = controller.counters();
  const auto add = [&](const char* name, std::uint64_t value) {
    entry.lines.push_back(std::string(name) + "=" + std::to_string(value));
  };
  add("scans", c.scans);
  add("items_created", c.items_created);
  add("items_adopted", c.items_adopted);
  add("items_closed", c.items_closed);
  add("items_tracked", controller.tracked_count());
  add("takt_strokes", c.takt_strokes);
  add("reject_reversals", c.reject_reversals);
  add("flip_conflicts", c.flip_conflicts);
  add("frames_processed", c.frames_processed);
  add("estimates_rejected", c.estimates_rejected);
  add("detections_unmatched", c.detections_unmatched);
  add("detections_duplicate", c.detections_duplicate);
  for (std::size_t o = 0; o < kOutcomeCount; ++o) {
    entry.lines.push_back("outcome." + std::string(to_string(static_cast<Outcome>(o))) + "=" +
                          std::to_string(c.outcomes[o]));
  }
  entry.lines.push_back("state=" + std::string(to_string(controller.state())));
  entry.lines.push_back(format("active_faults=0x%08x", controller.active_faults()));
  return entry;
}

// Time of an entry header's "t=" field, for ordering differences; "end" sorts last.
double header_time(const std::string& header) {
  const std::size_t at = header.find(" t=");
  if (at == std::string::npos) return 1e300;
  return std::strtod(header.c_str() + at + 3, nullptr);
}

}  // namespace

namespace {

// The recorded frames the replay measures, in the order the controller receives them, measured
// ahead in parallel batches: decoding a PNG and estimating take most of a replay's time, and
// each frame's result depends on that frame alone (the estimator keeps only scratch buffers),
// so the replay is the same with any number of threads.
class FrameMeasurer {
 public:
  struct Job {
    std::size_t camera = 0;
    const RecordedFrame* frame = nullptr;  // nullptr: `error` says why
    std::string error;
  };

  FrameMeasurer(const Recording& recording, const EstimatorParams& params, std::vector<Job> jobs,
                unsigned threads)
      : jobs_(std::move(jobs)),
        threads_(threads == 0 ? std::max(1U, std::thread::hardware_concurrency()) : threads),
        estimators_(threads_) {
    for (auto& per_thread : estimators_) {
      for (std::size_t c = 0; c < kCameraCount; ++c) {
        if (recording.cameras[c].has_frames) {
          per_thread[c].emplace(*recording.cameras[c].calibration, params);
        }
      }
    }
  }

  // Job i's result; jobs are taken in order. Rethrows the job's error.
  const FrameResult& get(std::size_t i) {
    if (i >= batch_end_) measure_batch(i);
    const std::size_t slot = i - batch_start_;
    if (errors_[slot]) std::rethrow_exception(errors_[slot]);
    return results_[slot];
  }

 private:
  // Frames per thread per batch: enough to keep the threads busy, few enough to bound memory.
  static constexpr std::size_t kFramesPerThread = 16;

  void measure_batch(std::size_t first) {
    batch_start_ = first;
    batch_end_ = std::min(jobs_.size(), first + kFramesPerThread * threads_);
    const std::size_t count = batch_end_ - batch_start_;
    results_.assign(count, FrameResult{});
    errors_.assign(count, nullptr);
    const auto work = [&](std::size_t worker) {
      for (std::size_t slot = worker; slot < count; slot += threads_) {
        const Job& job = jobs_[batch_start_ + slot];
        try {
          if (job.frame == nullptr) throw RecordingError(job.error);
          const cv::Mat bgr = decode_frame(*job.frame);
          results_[slot] = estimators_[worker][job.camera]->estimate(bgr, job.frame->exposure_ns,
                                                                     job.frame->sequence);
        } catch (...) {
          errors_[slot] = std::current_exception();
        }
      }
    };
    std::vector<std::thread> workers;
    for (std::size_t worker = 1; worker < threads_ && worker < count; ++worker) {
      workers.emplace_back(work, worker);
    }
    work(0);
    for (std::thread& worker : workers) worker.join();
  }

  std::vector<Job> jobs_;
  std::size_t threads_;
  std::vector<std::array<std::optional<FilletEstimator>, kCameraCount>> estimators_;
  std::size_t batch_start_ = 0;
  std::size_t batch_end_ = 0;
  std::vector<FrameResult> results_;
  std::vector<std::exception_ptr> errors_;
};

}  // namespace

ReplayResult replay(const Recording& recording, const ReplayOptions& options) {
  const std::string file = recording.path.string();
  ReplayResult result;
  std::vector<FrameMeasurer::Job> jobs;
  for (const RecordedEstimates& recorded : recording.estimates) {
    const std::size_t c = index(recorded.camera);
    if (!recording.cameras[c].has_frames) continue;
    const auto& frames = recording.cameras[c].frames;
    const auto frame = frames.find(recorded.frame.sequence);
    FrameMeasurer::Job job;
    job.camera = c;
    if (frame == frames.end()) {
      job.error = recorded.where + ": names frame " + std::to_string(recorded.frame.sequence) +
                  " but " + image_topic(recorded.camera) + " has no frame with that sequence";
    } else {
      job.frame = &frame->second;
    }
    jobs.push_back(std::move(job));
  }
  FrameMeasurer measurer(recording, options.estimator, std::move(jobs), options.measure_threads);
  std::size_t next_job = 0;
  std::optional<LineController> controller;
  if (!recording.scans.empty()) {
    LineConfig config;
    if (options.line_config) {
      config = *options.line_config;
    } else if (recording.line_config_yaml) {
      config = parse_line_config(*recording.line_config_yaml,
                                 file + ": attachment " + std::string(kLineConfigAttachment));
    } else {
      throw RecordingError(file + ": has line state but no " + std::string(kLineConfigAttachment) +
                           " attachment; pass the line configuration with --config");
    }
    controller.emplace(config);
    controller->reset();
  }

  std::array<CameraFrame, kCameraCount> current{};
  std::size_t next_estimates = 0;
  // Delivers every recorded estimate up to `time_ns`: re-measured for cameras with frames.
  const auto deliver_until = [&](std::int64_t time_ns) {
    while (next_estimates < recording.estimates.size() &&
           recording.estimates[next_estimates].log_time_ns <= time_ns) {
      const RecordedEstimates& recorded = recording.estimates[next_estimates++];
      const std::size_t c = index(recorded.camera);
      if (!recording.cameras[c].has_frames) {
        current[c] = recorded.frame;
        continue;
      }
      const FrameResult& measured = measurer.get(next_job++);
      // As live: a refused frame does not reach the controller (FrameResult::deliverable()).
      const CameraFrame estimates = measured.to_camera_frame();
      if (measured.deliverable()) current[c] = estimates;
      if (!same_frame(estimates, recorded.frame)) ++result.frames_differing_from_recording;
      result.entries.push_back(frame_entry(recorded.camera, measured.frame_time_ns, measured));
      ++result.frames;
    }
  };

  if (!controller) {
    deliver_until(std::numeric_limits<std::int64_t>::max());
    return result;
  }

  OutputImage out{};
  std::vector<std::pair<std::string, std::string>> previous;
  std::int64_t last_time_ns = 0;
  for (const RecordedScan& scan : recording.scans) {
    deliver_until(scan.input.time_ns);
    InputImage in = scan.input;
    in.cameras = current;
    controller->update(in, out);
    ++result.scans;
    last_time_ns = in.time_ns;

    GoldenEntry entry;
    entry.header = "scan " + std::to_string(scan.scan) + " " + time_s(in.time_ns);
    const auto fields = output_fields(out);
    if (scan.recorded_output) {
      ++result.scans_with_recorded_output;
      if (output_fields(*scan.recorded_output) != fields) {
        ++result.scans_differing_from_recording;
        if (!result.first_scan_differing) result.first_scan_differing = scan.scan;
      }
    }
    for (std::size_t f = 0; f < fields.size(); ++f) {
      if (previous.empty() || previous[f].second != fields[f].second) {
        entry.lines.push_back("out " + fields[f].first + " " + fields[f].second);
      }
    }
    previous = fields;
    while (auto event = controller->events().pop()) entry.lines.push_back(event_line(*event));
    while (auto record = controller->closed_records().pop()) {
      entry.lines.push_back(record_line(*record));
    }
    if (!entry.lines.empty()) result.entries.push_back(std::move(entry));
  }
  result.entries.push_back(end_entry(*controller, last_time_ns));
  return result;
}

void set_estimator_param(EstimatorParams& params, std::string_view assignment) {
  const std::size_t equals = assignment.find('=');
  if (equals == std::string_view::npos) {
    throw std::invalid_argument("--set " + std::string(assignment) + ": expected NAME=VALUE");
  }
  const std::string name(assignment.substr(0, equals));
  const std::string value_text(assignment.substr(equals + 1));
  static const std::map<std::string, double EstimatorParams::*> kDoubles = {
      {"working_mm_per_px", &EstimatorParams::working_mm_per_px},
      {"belt_chroma", &EstimatorParams::belt_chroma},
      {"belt_chroma_tolerance", &EstimatorParams::belt_chroma_tolerance},
      {"min_belt_brightness", &EstimatorParams::min_belt_brightness},
      {"min_belt_share", &EstimatorParams::min_belt_share},
      {"min_meat_contrast", &EstimatorParams::min_meat_contrast},
      {"min_blob_area_mm2", &EstimatorParams::min_blob_area_mm2},
      {"min_single_area_mm2", &EstimatorParams::min_single_area_mm2},
      {"max_single_area_mm2", &EstimatorParams::max_single_area_mm2},
      {"min_solidity", &EstimatorParams::min_solidity},
      {"max_defect_depth_mm", &EstimatorParams::max_defect_depth_mm},
      {"min_gap_mm", &EstimatorParams::min_gap_mm},
      {"axis_bias_rad", &EstimatorParams::axis_bias_rad},
      {"pose_offset_along_mm", &EstimatorParams::pose_offset_along_mm},
      {"pose_offset_toward_bulge_mm", &EstimatorParams::pose_offset_toward_bulge_mm},
      {"bend_slice_mm", &EstimatorParams::bend_slice_mm},
      {"bend_min_slice_width_mm", &EstimatorParams::bend_min_slice_width_mm},
      {"max_bend_per_mm", &EstimatorParams::max_bend_per_mm},
      {"sure_thick_end_skewness", &EstimatorParams::sure_thick_end_skewness},
      {"sure_bulge_skewness", &EstimatorParams::sure_bulge_skewness},
      {"redness_mid", &EstimatorParams::redness_mid},
      {"redness_scale", &EstimatorParams::redness_scale},
      {"texture_mm_per_px", &EstimatorParams::texture_mm_per_px},
      {"texture_fine_sigma_mm", &EstimatorParams::texture_fine_sigma_mm},
      {"texture_coarse_sigma_mm", &EstimatorParams::texture_coarse_sigma_mm},
      {"texture_mid", &EstimatorParams::texture_mid},
      {"texture_scale", &EstimatorParams::texture_scale},
      {"w_redness", &EstimatorParams::w_redness},
      {"w_texture", &EstimatorParams::w_texture},
      {"sure_side_score", &EstimatorParams::sure_side_score},
  };
  // Whole-number parameters and the largest value each takes.
  static const std::map<std::string, std::pair<int EstimatorParams::*, int>> kWholes = {
      {"border_margin_px", {&EstimatorParams::border_margin_px, 100}},
      {"bend_fit_passes", {&EstimatorParams::bend_fit_passes, 10}},
  };
  char* end = nullptr;
  const double value = std::strtod(value_text.c_str(), &end);
  if (value_text.empty() || end != value_text.c_str() + value_text.size() ||
      !std::isfinite(value)) {
    throw std::invalid_argument("--set " + std::string(assignment) + ": '" + value_text +
                                "' is not a finite number");
  }
  if (const auto whole = kWholes.find(name); whole != kWholes.end()) {
    const auto& [member, largest] = whole->second;
    if (value != std::floor(value) || value < 0.0 || value > largest) {
      throw std::invalid_argument("--set " + std::string(assignment) + ": " + name +
                                  " takes a whole number 0.." + std::to_string(largest));
    }
    params.*member = static_cast<int>(value);
    return;
  }
  const auto member = kDoubles.find(name);
  if (member == kDoubles.end()) {
    std::string known;
    for (const auto& [known_name, entry] : kWholes) known += known_name + ", ";
    for (const auto& [known_name, pointer] : kDoubles) known += known_name + ", ";
    known.resize(known.size() - 2);
    throw std::invalid_argument("--set " + std::string(assignment) + ": unknown parameter '" +
                                name + "' (known: " + known + ")");
  }
  params.*(member->second) = value;
}

// ------------------------------------------------------------------ golden files

std::string format_golden(const std::vector<GoldenEntry>& entries, std::string_view comment) {
  std::ostringstream text;
  std::istringstream comment_lines{std::string(comment)};
  for (std::string line; std::getline(comment_lines, line);) text << "# " << line << '\n';
  for (const GoldenEntry& entry : entries) {
    text << entry.header << '\n';
    for (const std::string& line : entry.lines) text << "  " << line << '\n';
  }
  return text.str();
}

std::vector<GoldenEntry> parse_golden(std::string_view text, std::string_view source_name) {
  std::vector<GoldenEntry> entries;
  std::istringstream lines{std::string(text)};
  std::size_t number = 0;
  for (std::string line; std::getline(lines, line);) {
    ++number;
    if (line.empty() || line[0] == '#') continue;
    if (line.rfind("  ", 0) == 0 && line.size() > 2 && line[2] != ' ') {
      if (entries.empty()) {
        throw std::runtime_error(std::string(source_name) + ":" + std::to_string(number) +
                                 ": indented line before the first entry header");
      }
      entries.back().lines.push_back(line.substr(2));
    } else if (line[0] == ' ') {
      throw std::runtime_error(std::string(source_name) + ":" + std::to_string(number) +
                               ": entry lines are indented by exactly two spaces");
    } else {
      entries.push_back({line, {}});
    }
  }
  return entries;
}

std::vector<GoldenDifference> compare_golden(const std::vector<GoldenEntry>& expected,
                                             const std::vector<GoldenEntry>& actual) {
  std::map<std::string, const GoldenEntry*> actual_by_header;
  for (const GoldenEntry& entry : actual) actual_by_header.emplace(entry.header, &entry);
  std::map<std::string, const GoldenEntry*> expected_by_header;
  for (const GoldenEntry& entry : expected) expected_by_header.emplace(entry.header, &entry);

  std::vector<GoldenDifference> differences;
  for (const GoldenEntry& entry : expected) {
    const auto it = actual_by_header.find(entry.header);
    if (it == actual_by_header.end()) {
      differences.push_back({entry.header, entry, std::nullopt});
    } else if (it->second->lines != entry.lines) {
      differences.push_back({entry.header, entry, *it->second});
    }
  }
  for (const GoldenEntry& entry : actual) {
    if (!expected_by_header.contains(entry.header)) {
      differences.push_back({entry.header, std::nullopt, entry});
    }
  }
  std::stable_sort(differences.begin(), differences.end(),
                   [](const GoldenDifference& a, const GoldenDifference& b) {
                     return header_time(a.header) < header_time(b.header);
                   });
  return differences;
}

std::string format_difference(const GoldenDifference& difference) {
  std::ostringstream text;
  if (!difference.actual) {
    text << difference.header << ": only in the golden\n";
    for (const std::string& line : difference.expected->lines) text << "  - " << line << '\n';
    return text.str();
  }
  if (!difference.expected) {
    text << difference.header << ": only in the replay\n";
    for (const std::string& line : difference.actual->lines) text << "  + " << line << '\n';
    return text.str();
  }
  text << difference.header << ": changed\n";
  // Lines of one side that the other lacks (counted, so repeated lines pair up), in order.
  std::map<std::string, int> actual_count;
  for (const std::string& line : difference.actual->lines) ++actual_count[line];
  std::map<std::string, int> expected_count;
  for (const std::string& line : difference.expected->lines) ++expected_count[line];
  for (const std::string& line : difference.expected->lines) {
    if (actual_count[line]-- <= 0) text << "  - " << line << '\n';
  }
  for (const std::string& line : difference.actual->lines) {
    if (expected_count[line]-- <= 0) text << "  + " << line << '\n';
  }
  return text.str();
}

}  // namespace fl::vision::record
