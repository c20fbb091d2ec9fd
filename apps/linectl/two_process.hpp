// linectl's two-process mode over DDS (issue 5 item 5; docs/dds.md, "Two-process mode"):
//   linectl twin serve --plant fast|dem --seed N --duration D [--json twin.json]
//       the plant in real time: publishes camera estimates, sensors and drive feedback,
//       applies the controller's commands, writes the ground-truth KPIs
//   linectl control --duration D [--json control.json] [--ledger ledger.csv]
//       the real ScanRuntime and LineController on DDS only; exits with the ledger summary
// Both take --domain (the DDS domain id; CYCLONEDDS_URI chooses the configuration).
// With --can IFACE both meet on a CAN bus instead, as on the line: the controller's CANopen
// master drives the twin's emulated CiA 402 drives and CiA 401 I/O modules (config/can.yaml),
// and only the cameras' estimates (and the controller's telemetry) stay on DDS. Without a
// twin, `linectl control --can can0` runs the line's real devices.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "fl/controller/runtime.hpp"

namespace fl::apps {

// `control --record FILE`: every scan's images as the controller saw them (line state and
// the cameras' estimates as they arrived), written as an MCAP recording that `linectl
// replay` runs through the controller again. on_scan() runs on the scan thread; drain() and
// close() on the thread that drains the controller's rings.
class ControlRecorder : public ScanRecorder {
 public:
  virtual void drain() = 0;  // writes what the scans handed over so far
  virtual void close() = 0;  // drains, then finishes the file (summary, index)
  [[nodiscard]] virtual std::uint64_t scans_written() const = 0;
  [[nodiscard]] virtual std::uint64_t scans_dropped() const = 0;  // handover ring full
};
// Opens the recording at `path`, with the line configuration's text attached.
using ControlRecorderFactory = std::function<std::unique_ptr<ControlRecorder>(
    const std::string& line_yaml_text, const std::string& path)>;

struct TwinServeArgs {
  std::string plant = "fast";
  std::uint64_t seed = 1;
  std::string duration = "60s";  // feeding time, the same meaning as linectl run
  std::string config;            // line configuration; default config/line.yaml
  std::string plant_config;      // default per plant
  std::string json_path;
  int domain = -1;            // -1: the domain of CYCLONEDDS_URI's configuration
  std::string wait = "30s";   // how long to wait for a controller before giving up
  std::string drain = "60s";  // longest run after the feeding time (as linectl run --realtime)
  int fifo_priority = 0;      // 1..99: SCHED_FIFO for the tick loop; 0: SCHED_OTHER
  std::string can_interface;  // set: the devices on this SocketCAN interface, not DDS topics
  std::string can_config;     // default can.yaml
};

struct ControlArgs {
  std::string duration = "60s";  // feeding time: the controller stops the line after it
  std::string config;            // line configuration; default config/line.yaml
  std::string json_path;
  std::string ledger_path;
  int domain = -1;
  std::string wait = "30s";   // how long to wait for the line's sensors before giving up
  std::string drain = "60s";  // longest wait for the line to stop after the stop request
  int fifo_priority = 0;
  bool lock_memory = false;
  int cpu_dma_latency_us = -1;
  std::string can_interface;  // set: drives and I/O through the CANopen master on it
  std::string can_config;     // default can.yaml
  std::string record_path;    // set: record every scan (needs record_factory)
  // Set by linectl (which links the recording library); empty in binaries without it.
  ControlRecorderFactory record_factory;
};

CLI::App* add_twin_subcommand(CLI::App& app, TwinServeArgs& args);
CLI::App* add_control_subcommand(CLI::App& app, ControlArgs& args);
// Exit codes of both: 0 the run completed and its books balance (twin: ground truth;
// control: the ledger); 2 bad options or configuration; 3 books unbalanced; 4 the peer never
// appeared or vanished; 1 anything else.
int twin_serve_command(const TwinServeArgs& args);
int control_command(const ControlArgs& args);

}  // namespace fl::apps
