// Kept apart from runtime.cpp so that a binary that runs other logic does not pull in the
// line controller.
#include "fl/controller/line_controller.hpp"
#include "fl/controller/line_status.hpp"
#include "fl/controller/runtime.hpp"

namespace fl {

void LineControllerLogic::update(const InputImage& in, OutputImage& out) {
  applied_ = in;
  if (start_requested_.exchange(false, std::memory_order_acq_rel)) applied_.start_request = true;
  if (stop_requested_.exchange(false, std::memory_order_acq_rel)) applied_.stop_request = true;
  if (ack_requested_.exchange(false, std::memory_order_acq_rel)) {
    applied_.fault_reset_request = true;
  }
  controller_.update(applied_, out);
}

void LineControllerLogic::after_scan(const InputImage& in, const OutputImage& out,
                                     const ScanTimingSample& timing) {
  if (status_ != nullptr) status_->publish(controller_, in, out, timing);
  if (recorder_ != nullptr) recorder_->on_scan(scans_, applied_, out);
  ++scans_;
}

void LineControllerLogic::on_overrun(const OverrunInfo& /*info*/) {
  overruns_seen_.fetch_add(1, std::memory_order_relaxed);
}

}  // namespace fl
