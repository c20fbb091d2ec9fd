// `linectl control --record FILE`: the controller's own recording, in the format of the
// twin's recordings without frames (docs/vision.md): each scan's sensors, drive feedback,
// command and status, and each camera's estimates in the scan that received them.
#pragma once

#include "two_process.hpp"

namespace fl::apps {

ControlRecorderFactory control_recorder_factory();

}  // namespace fl::apps
