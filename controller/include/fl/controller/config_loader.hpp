// Loads the line configuration (config/line.yaml) into LineConfig, strictly: every field is
// required, unknown keys are errors, and the values are checked against each other (belt
// sections, camera and station positions, speed limits). Either the whole configuration is
// valid and returned, or ConfigError lists every problem found; nothing is half-applied.
//
// File layout (see config/line.yaml): line, drives.<drive>, cameras.<camera>, then one block
// per station (bulk, leveller, takt, flip, reject, centring, multilane, squeeze, tolerance,
// tracking, watchdog). Angles are given in degrees (keys ending _deg) and stored in radians.
#pragma once

#include <filesystem>
#include <string_view>

#include "fl/controller/line_config.hpp"
#include "fl/controller/process_image.hpp"
#include "fl/controller/yaml_reader.hpp"

namespace fl {

// Throws ConfigError (also for a missing file or invalid YAML).
LineConfig load_line_config(const std::filesystem::path& file);

// The same from text; `source_name` stands for the file name in messages.
LineConfig parse_line_config(std::string_view yaml_text, std::string_view source_name);

// Names of drives and cameras as keys in the file: "multilane1_left", "orientation". The
// same as to_string (process_image.hpp), which new code should call.
inline std::string_view config_name(DriveId id) { return to_string(id); }
inline std::string_view config_name(CameraId id) { return to_string(id); }

}  // namespace fl
