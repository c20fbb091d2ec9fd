// Kept apart from runtime.cpp so that a binary that runs other logic does not pull in the
// line controller.
#include "fl/controller/line_controller.hpp"
#include "fl/controller/line_status.hpp"
#include "fl/controller/runtime.hpp"

namespace fl {

void LineControllerLogic::update(const InputImage& in, OutputImage& out) {
  if (start_requested_.exchange(false, std::memory_order_acq_rel)) controller_.request_start();
  if (stop_requested_.exchange(false, std::memory_order_acq_rel)) controller_.request_stop();
  if (ack_requested_.exchange(false, std::memory_order_acq_rel)) controller_.acknowledge_faults();
  controller_.update(in, out);
}

void LineControllerLogic::after_scan(const InputImage& in, const OutputImage& out,
                                     const ScanTimingSample& timing) {
  if (status_ != nullptr) status_->publish(controller_, in, out, timing);
}

void LineControllerLogic::on_overrun(const OverrunInfo& /*info*/) {
  overruns_seen_.fetch_add(1, std::memory_order_relaxed);
}

}  // namespace fl
