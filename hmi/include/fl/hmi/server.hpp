// The operator HMI's web server (civetweb): serves the page, pushes LineStatus snapshots as
// JSON over a WebSocket at the configured rate, and accepts operator commands (start, stop,
// acknowledge faults, and the twin's fault injection in simulation) from logged-in sessions
// only, over HTTP or the WebSocket. Everything runs on civetweb's worker threads and one
// broadcaster thread of its own: nothing here runs in, or waits for, the scan.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

#include "fl/controller/line_status.hpp"
#include "fl/hmi/hmi_config.hpp"

namespace fl::hmi {

// What a command does; called on a server thread, so each must be thread-safe
// (LineControllerLogic's request_* are).
struct HmiCommands {
  std::function<void()> start_line;
  std::function<void()> stop_line;
  std::function<void()> acknowledge_faults;
  // Simulation only (empty against the real line): raise or clear a fault in the twin.
  // Returns an empty string, or why the request is invalid.
  std::function<std::string(std::string_view fault, std::string_view target, bool active)>
      twin_fault;
};

class HmiServer {
 public:
  using ClockNs = std::function<std::int64_t()>;  // monotonic; session expiry and throttling

  // `status` is read by the server's broadcaster thread only (the buffer's one consumer).
  // `layout` is sent to each page as it connects (layout_to_json). Nothing starts yet.
  HmiServer(HmiConfig config, TripleBuffer<LineStatus>& status, const nlohmann::json& layout,
            HmiCommands commands, ClockNs clock = {});
  ~HmiServer();  // stops
  HmiServer(const HmiServer&) = delete;
  HmiServer& operator=(const HmiServer&) = delete;

  // Binds and starts the threads. Throws std::runtime_error with civetweb's reason (address
  // in use, no such address, ...).
  void start();
  void stop();
  // The bound port (the chosen one when the configuration says 0); 0 before start().
  [[nodiscard]] int port() const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace fl::hmi
