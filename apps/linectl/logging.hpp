// linectl's log output: the console as before when run by hand, the journal's priorities when
// systemd runs it, and optionally a size-rotated log file.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

namespace fl::apps {

struct LogOptions {
  std::string level = "info";  // trace, debug, info, warn, error
  std::string file;            // empty: no log file
  std::string file_size = "10M";
  std::size_t file_count = 5;  // rotated files kept beside the current one
};

// Bytes from "4096", "512K", "10M" or "1G" (powers of 1024), or nullopt when the text is not a
// positive size.
std::optional<std::size_t> parse_byte_size(std::string_view text);

// True when stderr is the journal stream systemd connected (JOURNAL_STREAM names its device
// and inode), so that lines are written with sd-daemon "<N>" priority prefixes.
bool stderr_is_journal();

// Installs the default logger. Throws std::runtime_error naming a log file it cannot open or
// a size it cannot read.
void setup_logging(const LogOptions& options);

}  // namespace fl::apps
