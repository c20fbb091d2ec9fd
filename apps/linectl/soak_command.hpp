// linectl soak: the controller closed loop against the fast plant on the real-time schedule
// for a long time (one hour by default), judged by flat memory after a warm-up, no scan woken
// late beyond a bound under SCHED_FIFO, and zero lost fillets (docs/deployment.md, "Soak").
//   linectl soak [--duration 1h] [--fifo 80] [--out soak] [--warm-up 5m]
// Writes soak.json (verdict, figures, timeline), soak_timeline.csv, soak.html (the verdict and
// plots of memory and wake-up latency over time) and ledger.csv into --out.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <string>

namespace fl::apps {

struct SoakArgs {
  std::string duration = "1h";  // feeding time
  std::uint64_t seed = 1;
  std::string config;        // line configuration; default line.yaml from the search path
  std::string plant_config;  // default plant_fast.yaml
  std::string out_directory = "soak";
  int fifo_priority = 80;  // the service's priority (deploy/fillet-line.service)
  bool allow_no_fifo = false;
  bool lock_memory = true;
  int cpu_dma_latency_us = 0;
  bool latency_probe = true;  // the machine's baseline beside the scan (LatencyProbe)  // as the
                              // service holds it (deploy/fillet-line.default)
  std::string warm_up = "5m";
  std::string sample_every = "10s";
  std::uint64_t max_resident_growth_kib = 1024;
  double max_wakeup_latency_us = 1000.0;
  bool quiet = false;
};

CLI::App* add_soak_subcommand(CLI::App& app, SoakArgs& args);
// Exit codes: 0 passed; 1 failed (the report says why) or an error; 2 bad options or
// configuration.
int soak_command(const SoakArgs& args);

}  // namespace fl::apps
