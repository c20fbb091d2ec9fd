#include "fl/controller/ledger.hpp"

#include "fl/controller/line_controller.hpp"

namespace fl {

const char* to_string(Outcome outcome) {
  switch (outcome) {
    case Outcome::kInTransit:
      return "in_transit";
    case Outcome::kPlaced:
      return "placed";
    case Outcome::kRejectedNotSingulated:
      return "rejected_not_singulated";
    case Outcome::kRejectedUnclassified:
      return "rejected_unclassified";
    case Outcome::kRejectedCollateral:
      return "rejected_collateral";
    case Outcome::kRejectedMisaligned:
      return "rejected_misaligned";
    case Outcome::kRejectedUnverified:
      return "rejected_unverified";
    case Outcome::kRejectedUntracked:
      return "rejected_untracked";
    case Outcome::kLost:
      return "lost";
    case Outcome::kCount:
      break;
  }
  return "invalid";
}

const char* to_string(LostReason reason) {
  switch (reason) {
    case LostReason::kNone:
      return "none";
    case LostReason::kNotSeenByCamera:
      return "not_seen_by_camera";
    case LostReason::kStaleEstimates:
      return "stale_estimates";
    case LostReason::kTrackerOverflow:
      return "tracker_overflow";
    case LostReason::kLineStopped:
      return "line_stopped";
    case LostReason::kRunEnded:
      return "run_ended";
  }
  return "invalid";
}

const char* to_string(EventCode code) {
  switch (code) {
    case EventCode::kItemCreated:
      return "item_created";
    case EventCode::kItemClosed:
      return "item_closed";
    case EventCode::kEstimateNotFinite:
      return "estimate_not_finite";
    case EventCode::kEstimateOutOfRange:
      return "estimate_out_of_range";
    case EventCode::kEstimateStale:
      return "estimate_stale";
    case EventCode::kFrameOutOfOrder:
      return "frame_out_of_order";
    case EventCode::kDetectionUnmatched:
      return "detection_unmatched";
    case EventCode::kDuplicateDetection:
      return "duplicate_detection";
    case EventCode::kFlipConflict:
      return "flip_conflict";
    case EventCode::kCameraSilent:
      return "camera_silent";
    case EventCode::kEstimateFlood:
      return "estimate_flood";
    case EventCode::kItemAdopted:
      return "item_adopted";
    case EventCode::kRejectReversal:
      return "reject_reversal";
    case EventCode::kFaultRaised:
      return "fault_raised";
    case EventCode::kFaultCleared:
      return "fault_cleared";
    case EventCode::kStateChanged:
      return "state_changed";
  }
  return "invalid";
}

const char* to_string(FaultCode code) {
  switch (code) {
    case FaultCode::kEstop:
      return "estop";
    case FaultCode::kDriveFault:
      return "drive_fault";
    case FaultCode::kLevellerOverload:
      return "leveller_overload";
    case FaultCode::kCycleOverrun:
      return "cycle_overrun";
    case FaultCode::kCameraSilent:
      return "camera_silent";
    case FaultCode::kEstimateFlood:
      return "estimate_flood";
    case FaultCode::kTrackerOverflow:
      return "tracker_overflow";
    case FaultCode::kCount:
      break;
  }
  return "invalid";
}

}  // namespace fl
