#include "logging.hpp"

#include <spdlog/sinks/base_sink.h>
#include <spdlog/sinks/rotating_file_sink.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <sys/stat.h>
#include <unistd.h>

#include <charconv>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <vector>

namespace fl::apps {
namespace {

// sd-daemon(3) priorities, as journald reads them from a "<N>" line prefix.
int journal_priority(spdlog::level::level_enum level) {
  switch (level) {
    case spdlog::level::critical:
      return 2;
    case spdlog::level::err:
      return 3;
    case spdlog::level::warn:
      return 4;
    case spdlog::level::info:
      return 6;
    default:
      return 7;  // debug, trace
  }
}

// Writes each line of a message with its priority prefix and no timestamp (journald stamps
// every entry). Each line is prefixed because journald makes one entry per line: a multi-line
// configuration error keeps its priority on every line.
class JournalStreamSink final : public spdlog::sinks::base_sink<std::mutex> {
 protected:
  void sink_it_(const spdlog::details::log_msg& msg) override {
    std::string_view text(msg.payload.data(), msg.payload.size());
    if (!text.empty() && text.back() == '\n') text.remove_suffix(1);
    const int priority = journal_priority(msg.level);
    std::size_t start = 0;
    while (start <= text.size()) {
      std::size_t end = text.find('\n', start);
      if (end == std::string_view::npos) end = text.size();
      const std::string_view line = text.substr(start, end - start);
      std::fprintf(stderr, "<%d>%.*s\n", priority, static_cast<int>(line.size()), line.data());
      start = end + 1;
    }
  }
  void flush_() override { std::fflush(stderr); }
};

}  // namespace

std::optional<std::size_t> parse_byte_size(std::string_view text) {
  std::size_t value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc{} || end == text.data() || value == 0) return std::nullopt;
  const std::string_view unit(end, static_cast<std::size_t>(text.data() + text.size() - end));
  std::size_t multiplier = 1;
  if (unit == "K") {
    multiplier = std::size_t{1} << 10;
  } else if (unit == "M") {
    multiplier = std::size_t{1} << 20;
  } else if (unit == "G") {
    multiplier = std::size_t{1} << 30;
  } else if (!unit.empty()) {
    return std::nullopt;
  }
  if (value > std::numeric_limits<std::size_t>::max() / multiplier) return std::nullopt;
  return value * multiplier;
}

bool stderr_is_journal() {
  const char* stream = std::getenv("JOURNAL_STREAM");
  if (stream == nullptr) return false;
  unsigned long long device = 0;
  unsigned long long inode = 0;
  if (std::sscanf(stream, "%llu:%llu", &device, &inode) != 2) return false;
  struct stat status {};
  if (fstat(STDERR_FILENO, &status) != 0) return false;
  // Inherited by a child whose stderr was redirected elsewhere: compare, as systemd advises.
  return static_cast<unsigned long long>(status.st_dev) == device &&
         static_cast<unsigned long long>(status.st_ino) == inode;
}

void setup_logging(const LogOptions& options) {
  std::vector<spdlog::sink_ptr> sinks;
  if (stderr_is_journal()) {
    sinks.push_back(std::make_shared<JournalStreamSink>());
  } else {
    sinks.push_back(std::make_shared<spdlog::sinks::stderr_color_sink_mt>());
  }
  if (!options.file.empty()) {
    const std::optional<std::size_t> max_bytes = parse_byte_size(options.file_size);
    if (!max_bytes) {
      throw std::runtime_error("--log-file-size " + options.file_size +
                               ": not a positive size (examples: 512K, 10M, 1G)");
    }
    try {
      sinks.push_back(std::make_shared<spdlog::sinks::rotating_file_sink_mt>(
          options.file, *max_bytes, options.file_count));
    } catch (const spdlog::spdlog_ex& error) {
      throw std::runtime_error("--log-file " + options.file + ": cannot open: " + error.what());
    }
    // Timestamps for the file; the journal and the console keep their own.
    sinks.back()->set_pattern("%Y-%m-%dT%H:%M:%S.%e%z [%l] %v");
  }
  auto logger = std::make_shared<spdlog::logger>("linectl", sinks.begin(), sinks.end());
  logger->set_level(spdlog::level::from_str(options.level));
  // Warnings reach the file at once; the rest within a second, off the scan thread.
  logger->flush_on(spdlog::level::warn);
  spdlog::set_default_logger(logger);
  if (!options.file.empty()) spdlog::flush_every(std::chrono::seconds(1));
}

}  // namespace fl::apps
