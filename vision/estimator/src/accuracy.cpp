#include "fl/vision/accuracy.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

namespace fl::vision {
namespace {

constexpr double kDegPerRad = 180.0 / std::numbers::pi;

// Confusion column of an estimate: 0 and 1 the classes in enum order, 2 unknown.
template <typename Class>
std::size_t column(Class estimate) {
  return estimate == Class::kUnknown ? 2 : static_cast<std::size_t>(estimate) - 1;
}

template <typename Class>
void add_to(Confusion& confusion, Class truth, Class estimate) {
  if (truth == Class::kUnknown) return;  // truth always knows; guard a malformed one
  ++confusion[static_cast<std::size_t>(truth) - 1][column(estimate)];
}

double distance_mm(const FilletEstimate& estimate, const TrueFillet& fillet) {
  return std::hypot(static_cast<double>(estimate.x_mm) - fillet.x_mm,
                    static_cast<double>(estimate.y_mm) - fillet.y_mm);
}

double share(std::uint64_t part, std::uint64_t whole) {
  return whole == 0 ? 1.0 : static_cast<double>(part) / static_cast<double>(whole);
}

std::string why_missed(const FrameResult& result, const std::vector<const FilletEstimate*>& blobs,
                       const TrueFillet& fillet) {
  if (result.status != FrameStatus::kOk) {
    return "frame refused: " + std::string(to_string(result.status));
  }
  double nearest_mm = -1.0;
  for (const FilletEstimate* blob : blobs) {
    const double d = distance_mm(*blob, fillet);
    if (nearest_mm < 0.0 || d < nearest_mm) nearest_mm = d;
  }
  std::string why;
  if (nearest_mm >= 0.0) {
    why = "nearest fillet blob " + std::to_string(static_cast<int>(std::lround(nearest_mm))) +
          " mm away";
  }
  // Blobs without a pose cannot be placed; their statuses say what the fillet became.
  for (const BlobResult& blob : result.blobs) {
    if (blob.status == BlobStatus::kFillet) continue;
    why += (why.empty() ? "" : "; ") + std::string("a blob ") + std::string(to_string(blob.status));
  }
  return why.empty() ? "no blob" : why;
}

}  // namespace

double angle_between_rad(double a_rad, double b_rad) {
  const double difference = std::remainder(a_rad - b_rad, 2.0 * std::numbers::pi);
  return std::abs(difference);
}

double percentile(std::vector<double> values, double share_of_values) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const double rank = std::ceil(share_of_values * static_cast<double>(values.size()));
  const auto index = static_cast<std::size_t>(std::max(rank, 1.0)) - 1;
  return values[std::min(index, values.size() - 1)];
}

void AccuracyTally::add_frame(const FrameResult& result, const std::vector<TrueFillet>& truth) {
  ++counts_.frames;
  if (result.status != FrameStatus::kOk) ++counts_.frames_not_ok;

  std::vector<const FilletEstimate*> blobs;
  for (const BlobResult& blob : result.blobs) {
    if (blob.status == BlobStatus::kFillet) blobs.push_back(&blob.estimate);
  }

  for (const FilletEstimate* blob : blobs) {
    const bool near_a_fillet = std::any_of(truth.begin(), truth.end(), [&](const TrueFillet& f) {
      return distance_mm(*blob, f) < options_.group_gate_mm;
    });
    if (!near_a_fillet) ++counts_.phantoms;
  }

  for (const TrueFillet& fillet : truth) {
    if (!fillet.singulated || !fillet.fully_visible) continue;
    if (fillet.gap_mm < options_.near_gap_mm + options_.near_gap_band_mm) {
      // A near pair is right when no blob near it claims a singulated fillet there.
      const bool called_single = std::any_of(blobs.begin(), blobs.end(), [&](const auto* blob) {
        return blob->singulated && distance_mm(*blob, fillet) < options_.match_gate_mm;
      });
      if (fillet.gap_mm < options_.near_gap_mm) {
        ++counts_.near_singles;
        if (!called_single) ++counts_.near_reported_not_singulated;
      } else {
        ++counts_.borderline_singles;
        if (!called_single) ++counts_.borderline_reported_not_singulated;
      }
      continue;
    }
    ++counts_.singles;
    const FilletEstimate* nearest = nullptr;
    double nearest_mm = options_.match_gate_mm;
    for (const FilletEstimate* blob : blobs) {
      const double d = distance_mm(*blob, fillet);
      if (d < nearest_mm) {
        nearest_mm = d;
        nearest = blob;
      }
    }
    if (nearest == nullptr) {
      missed_.push_back({result.sequence, fillet.x_mm, fillet.y_mm, fillet.angle_rad,
                         why_missed(result, blobs, fillet)});
      continue;
    }
    ++counts_.detected;
    const double error_rad =
        angle_between_rad(static_cast<double>(nearest->angle_rad), fillet.angle_rad);
    angle_errors_deg_.push_back(error_rad * kDegPerRad);
    position_errors_mm_.push_back(nearest_mm);
    if (error_rad < std::numbers::pi / 2) ++counts_.thick_end_right;
    add_to(counts_.hand, fillet.hand, nearest->hand);
    add_to(counts_.side, fillet.side, nearest->side);
    if (nearest->hand != fillet.hand || nearest->side != fillet.side) {
      misjudged_.push_back({result.sequence, fillet.x_mm, fillet.y_mm, fillet.angle_rad,
                            fillet.hand, nearest->hand, fillet.side, nearest->side,
                            nearest->confidence});
    }
    if (!nearest->singulated) ++counts_.singles_flagged;
  }

  // Touching groups: each counts once, when all its members are wholly in view (a group cut
  // by the image border is one cut blob, which the estimator rightly does not judge).
  std::vector<int> groups_seen;
  for (const TrueFillet& fillet : truth) {
    if (fillet.singulated || fillet.group_id < 0) continue;
    if (std::find(groups_seen.begin(), groups_seen.end(), fillet.group_id) != groups_seen.end()) {
      continue;
    }
    groups_seen.push_back(fillet.group_id);
    const bool whole_group_in_view =
        std::all_of(truth.begin(), truth.end(), [&](const TrueFillet& member) {
          return member.group_id != fillet.group_id || member.fully_visible;
        });
    if (!whole_group_in_view) continue;
    ++counts_.groups;
    bool seen = false;
    bool all_flagged = true;
    for (const FilletEstimate* blob : blobs) {
      const bool near_member =
          std::any_of(truth.begin(), truth.end(), [&](const TrueFillet& member) {
            return member.group_id == fillet.group_id &&
                   distance_mm(*blob, member) < options_.group_gate_mm;
          });
      if (!near_member) continue;
      seen = true;
      all_flagged = all_flagged && !blob->singulated;
    }
    if (seen && all_flagged) ++counts_.groups_flagged;
  }
}

AccuracySummary AccuracyTally::summary() const {
  AccuracySummary summary = counts_;
  summary.angle_error_p50_deg = percentile(angle_errors_deg_, 0.50);
  summary.angle_error_p95_deg = percentile(angle_errors_deg_, 0.95);
  summary.angle_error_max_deg = percentile(angle_errors_deg_, 1.0);
  summary.position_error_p50_mm = percentile(position_errors_mm_, 0.50);
  summary.position_error_p95_mm = percentile(position_errors_mm_, 0.95);
  summary.position_error_max_mm = percentile(position_errors_mm_, 1.0);
  summary.hand_correct_share = share(summary.hand[0][0] + summary.hand[1][1], summary.detected);
  summary.side_correct_share = share(summary.side[0][0] + summary.side[1][1], summary.detected);
  summary.singulation_precision =
      share(summary.groups_flagged, summary.groups_flagged + summary.singles_flagged);
  summary.singulation_recall = share(summary.groups_flagged, summary.groups);
  return summary;
}

}  // namespace fl::vision
