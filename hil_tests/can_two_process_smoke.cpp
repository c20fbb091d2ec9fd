// The two-process closed loop over a real kernel CAN stack (issue 5, "Testing against real
// stacks"): `control --can vcan0` and `twin serve --plant fast --can vcan0` as two processes
// inside the qemu guest that drivers/tests/run_vcan_tests.sh boots. The controller's CANopen
// master starts up, configures and drives the twin's emulated CiA 402 drives and CiA 401 I/O
// modules over SocketCAN; the cameras' estimates come over Cyclone DDS on the guest's
// loopback. candump (/opt/candump) records the bus as an independent peer.
//
// One self-contained binary, because the guest has no project tree and 256 MB of memory:
// with arguments it is linectl's `control` and `twin serve` (the same code,
// fl_linectl_two_process, without linectl's vision and its OpenCV); with none, as the
// guest's init runs it, it writes the embedded configuration to /tmp and runs the tests,
// starting itself twice. Not run on the host: its kernel has no CAN.
#include <gtest/gtest.h>
#include <net/if.h>
#include <signal.h>
#include <spdlog/spdlog.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cctype>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "can_smoke_files.hpp"
#include "candump_peer.hpp"
#include "cli_support.hpp"
#include "duration.hpp"
#include "fl/apps/closed_loop.hpp"
#include "fl/controller/config_loader.hpp"
#include "fl/drivers/can_config.hpp"
#include "process_support.hpp"
#include "two_process.hpp"

namespace fl {
namespace {

namespace fs = std::filesystem;
using hil::load;
using hil::spawn;
using hil::text;

constexpr const char* kInterface = "vcan0";
const fs::path kWorkDir = "/tmp/can_smoke";
// 20 s of feeding: some 20 fillets at the design rate of 60 per minute, enough to see them
// flipped, centred and placed through the bus, and short enough for the emulated guest CPU.
constexpr const char* kDuration = "20s";
// The longest a process may run: 20 s of feeding, the drain (the last fillet's way to the
// outfeed, under 30 s), start-up, and a factor of two for the emulated CPU.
constexpr auto kRunLimit = std::chrono::seconds(150);
#ifdef FL_CAN_SOAK
// Issue 5's ten minutes, some 600 fillets: the in-spec share then moves by 0.17 points per
// fillet, so its 1-point bound is the comparison's, not one fillet's luck.
constexpr const char* kSoakDuration = "10m";
// Both processes keep real time, so the run takes its ten minutes, the drain (under 30 s) and
// the start-up whatever the emulated CPU's speed; five minutes more before it counts as hung.
constexpr auto kSoakRunLimit = std::chrono::seconds(900);
// Issue 5's bound on the KPIs against the lock-step run, in points of the in-spec share; and
// the throughputs, which two real-time processes reproduce to within a fillet or two a
// minute (0.4 % over DDS on the host, docs/benchmarks.md), within 2 %.
constexpr double kInSpecTolerance = 0.01;
constexpr double kThroughputTolerance = 0.02;
#endif

// The guest's init brings up vcan0 but not the loopback interface Cyclone's configuration
// names: up it here (as root in the guest).
bool bring_up_loopback() {
  const int fd = socket(AF_INET, SOCK_DGRAM, 0);
  if (fd < 0) return false;
  ifreq request{};
  std::strncpy(request.ifr_name, "lo", IFNAMSIZ - 1);
  bool ok = ioctl(fd, SIOCGIFFLAGS, &request) == 0;
  if (ok && (request.ifr_flags & IFF_UP) == 0) {
    request.ifr_flags = static_cast<short>(request.ifr_flags | IFF_UP);
    ok = ioctl(fd, SIOCSIFFLAGS, &request) == 0;
  }
  close(fd);
  return ok;
}

void write_file(const fs::path& path, const char* contents) {
  std::ofstream out(path);
  out << contents;
  ASSERT_TRUE(out.good()) << path;
}

// The exit code, or -1 after killing a process that ran past `limit`.
int wait_exit_within(pid_t pid, std::chrono::seconds limit) {
  const auto deadline = std::chrono::steady_clock::now() + limit;
  int status = 0;
  while (waitpid(pid, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() > deadline) {
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
      return -1;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return hil::exit_code(status);
}

// Waits for the controller's scan to start (its log says so), then 8 s more: the first
// fillets are then past the takt beam, on the belts.
void wait_for_scanning(const fs::path& control_log) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (text(control_log).find("scanning") == std::string::npos &&
         std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  std::this_thread::sleep_for(std::chrono::seconds(8));
}

// This binary: the children are its own `control` and `twin serve`.
std::string self() { return fs::read_symlink("/proc/self/exe").string(); }

// Both processes for 60 s of feeding (never reached), each writing its JSON into `dir`,
// returned once the controller's scan has run 8 s: for the tests that kill one of them.
struct RunningPair {
  pid_t twin = -1;
  pid_t control = -1;
};

RunningPair start_pair(const fs::path& dir, const std::vector<std::string>& environment) {
  fs::create_directories(dir);
  RunningPair run;
  run.twin = spawn({self(), "twin", "serve", "--plant", "fast", "--seed", "1", "--can", kInterface,
                    "--duration", "60s", "--wait", "60s", "--json", (dir / "twin.json").string()},
                   dir / "twin.log", environment);
  run.control = spawn({self(), "control", "--can", kInterface, "--duration", "60s", "--wait", "60s",
                       "--json", (dir / "control.json").string()},
                      dir / "control.log", environment);
  wait_for_scanning(dir / "control.log");
  return run;
}

// Kills `victim` with SIGKILL (checking that it died of it) and returns the survivor's exit
// code, or -1 when it ran past kRunLimit.
int kill_and_wait(pid_t victim, pid_t survivor) {
  kill(victim, SIGKILL);
  EXPECT_EQ(wait_exit_within(victim, kRunLimit), 128 + SIGKILL);
  return wait_exit_within(survivor, kRunLimit);
}

// `text` with every number that follows `key` multiplied by `factor`.
std::string with_values_scaled(const std::string& text, std::string_view key, double factor) {
  std::string scaled;
  std::size_t from = 0;
  for (std::size_t at = text.find(key); at != std::string::npos; at = text.find(key, from)) {
    const std::size_t digits = at + key.size();
    std::size_t end = digits;
    while (end < text.size() &&
           (std::isdigit(static_cast<unsigned char>(text[end])) != 0 || text[end] == '.')) {
      ++end;
    }
    scaled.append(text, from, digits - from);
    char number[32];
    std::snprintf(number, sizeof number, "%g",
                  factor * std::stod(text.substr(digits, end - digits)));
    scaled += number;
    from = end;
  }
  scaled.append(text, from);
  return scaled;
}

// The product's can.yaml with every heartbeat timeout four times longer. The guest is one
// emulated CPU at a tenth of the host's speed, and the host runs other tests beside it: a 60 ms
// stall of the whole guest (seen once, while the host built code) lost the safety node's
// 20 ms heartbeat and stopped the line, a correct reaction to a fault no device had. Losses of
// devices that really fall silent are still seen, at 0.24 to 0.6 s.
std::string can_yaml_for_the_emulated_guest() {
  return with_values_scaled(test::kCanYamlText, "heartbeat_timeout_ms: ", 4);
}

// The product's line.yaml stretched for the guest, as can.yaml's heartbeats are: seven times
// the overruns in a row that fault the line (21 scans, 0.21 s, instead of 3) and cameras
// silent or stale after four times their max_age_s. On 2026-11-28's slower host, runs that
// were otherwise clean faulted on three overrunning scans in a row, or raised camera_silent
// for a few scans, whenever the guest's one emulated CPU stalled for 0.1 s under both
// processes: correct reactions to faults no device had. A scan stuck for good, or a camera
// that stops, is still a fault (after 0.21 s, and 0.24 to 0.4 s).
//
// Likewise the stall watchdog, seven times its 10 periods (0.7 s): on 2026-11-28 the guest's
// CPU stalled 107 ms while the controller waited for its kill test, and the watchdog faulted a
// line no device had failed. A scan thread that stops for good still faults it.
std::string line_yaml_for_the_emulated_guest() {
  return with_values_scaled(
      with_values_scaled(with_values_scaled(test::kLineYamlText, "overrun_fault_cycles: ", 7),
                         "stall_fault_cycles: ", 7),
      "max_age_s: ", 4);
}

class CanTwoProcess : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    fs::create_directories(kWorkDir / "config");
    write_file(kWorkDir / "config" / "line.yaml", line_yaml_for_the_emulated_guest().c_str());
    write_file(kWorkDir / "config" / "can.yaml", can_yaml_for_the_emulated_guest().c_str());
    write_file(kWorkDir / "config" / "plant_fast.yaml", test::kPlantFastYamlText);
    write_file(kWorkDir / "config" / "cyclonedds.xml", test::kCycloneLoopbackXml);
  }
  void SetUp() override {
    if (if_nametoindex(kInterface) == 0) GTEST_FAIL() << kInterface << " missing: run in the guest";
    ASSERT_TRUE(bring_up_loopback()) << "lo: " << std::strerror(errno);
  }
  // The children find the configuration through the product's own search path.
  static std::vector<std::string> environment() {
    return {"FL_CONFIG_DIR=" + (kWorkDir / "config").string(),
            "CYCLONEDDS_URI=file://" + (kWorkDir / "config" / "cyclonedds.xml").string()};
  }
};

// What one run of both processes over vcan0 left: exit codes, logs, both JSONs and the
// frames the independent peer recorded.
struct VcanRun {  // NOLINT(bugprone-exception-escape): nlohmann::json's implicit members
  int control_exit = -1;
  int twin_exit = -1;
  std::string logs;
  nlohmann::json control_kpis;
  nlohmann::json twin_kpis;
  std::vector<std::string> frames;
  bool peer = false;
};

// `control --can vcan0` and `twin serve --plant fast --can vcan0` for `duration` of feeding,
// seed 1, candump beside them; either is killed when it runs past `limit`.
VcanRun run_line_over_vcan(const fs::path& dir, const char* duration, std::chrono::seconds limit,
                           const std::vector<std::string>& environment) {
  fs::create_directories(dir);
  // Only the frames the cross-check counts (SYNC, node 2's heartbeat): recording all of some
  // 3000 a second kept the guest's one emulated CPU so busy on 2026-11-28's slower host that
  // the twin's ticks ran late from the start and the line faulted within a second.
  drivers::test::Candump candump((dir / "candump.log").string(), "vcan0,080:7FF,702:7FF");
  VcanRun run;
  run.peer = candump.running();
  const pid_t twin =
      spawn({self(), "twin", "serve", "--plant", "fast", "--seed", "1", "--can", kInterface,
             "--duration", duration, "--wait", "60s", "--json", (dir / "twin.json").string()},
            dir / "twin.log", environment);
  const pid_t control = spawn({self(), "control", "--can", kInterface, "--duration", duration,
                               "--wait", "60s", "--json", (dir / "control.json").string()},
                              dir / "control.log", environment);
  run.control_exit = wait_exit_within(control, limit);
  run.twin_exit = wait_exit_within(twin, limit);
  run.frames = candump.finish();
  run.logs = "--- control\n" + text(dir / "control.log") + "--- twin\n" + text(dir / "twin.log");
  if (run.control_exit == 0 && run.twin_exit == 0) {
    run.control_kpis = load(dir / "control.json");
    run.twin_kpis = load(dir / "twin.json");
  }
  return run;
}

// What every clean run over the bus shows, however long it fed.
void expect_a_clean_run(const VcanRun& run) {
  const nlohmann::json& control_kpis = run.control_kpis;
  const nlohmann::json& twin_kpis = run.twin_kpis;
  // Both books balance, and fillets went all the way through: flipped, centred, placed.
  EXPECT_TRUE(control_kpis["ledger"]["balanced"].get<bool>());
  EXPECT_EQ(control_kpis["ledger"]["records_dropped"].get<int>(), 0);
  EXPECT_TRUE(twin_kpis["truth"]["balanced"].get<bool>());
  EXPECT_GT(twin_kpis["truth"]["outfeed"].get<int>(), 0);
  EXPECT_EQ(twin_kpis["truth"]["on_line_at_end"].get<int>(), 0);
  // The two books agree: the controller's items are the fillets the twin fed, tracked through
  // the bus's beams and encoders (a touching pair is one item), and what it placed left the
  // twin's outfeed.
  const int items = control_kpis["ledger"]["items_created"].get<int>();
  const int placed = control_kpis["ledger"]["outcomes"]["placed"].get<int>();
  EXPECT_GT(items, 0);
  EXPECT_LE(items, twin_kpis["truth"]["fed"].get<int>());
  EXPECT_GT(placed, 0);
  EXPECT_LE(placed, twin_kpis["truth"]["outfeed"].get<int>());
  EXPECT_EQ(control_kpis["runtime"]["fault"].get<std::string>(), "none");
  EXPECT_FALSE(control_kpis["runtime"]["line_faulted"].get<bool>());
  // The bus: no frame the master could not place, none refused, no node lost.
  const nlohmann::json& can = control_kpis["can"];
  EXPECT_GT(can["syncs_sent"].get<int>(), 0);
  EXPECT_EQ(can["malformed_frames"].get<int>(), 0);
  EXPECT_EQ(can["unknown_cob_id"].get<int>(), 0);
  EXPECT_EQ(can["nodes_lost"].get<int>(), 0);
  EXPECT_EQ(can["error_state"].get<std::string>(), "error active");
  EXPECT_GT(twin_kpis["twin"]["can"]["syncs_received"].get<int>(), 0);
  EXPECT_GT(control_kpis["dds"]["estimate_to_command_us"]["count"].get<int>(), 0);
  // SYNC as the kernel stamped it going out: every frame confirmed, and the scan's absolute
  // wake-ups keep its mean interval at the 10 ms period (20 %: skipped periods after
  // overruns in the emulated guest lengthen single intervals by a period each).
  const nlohmann::json& wire = can["on_the_wire"];
  EXPECT_GT(wire["syncs"].get<int>(), 0);
  EXPECT_EQ(wire["frames_unconfirmed"].get<int>(), 0);
  // The start-up's resets and the shut-down's NMT stop were the master's own: no fault report.
  EXPECT_EQ(control_kpis["dds"]["fault_reports_published"].get<int>(), 0);
  EXPECT_NEAR(wire["sync_period_mean_ms"].get<double>(), 10.0, 2.0);
  // Issue 5's latency to the drive command on the bus: each frame the controller read, to the
  // SYNC that applied its scan's RPDOs, as the kernel stamped it. Measured, not judged: the
  // emulated guest is no place for a real-time bound (docs/benchmarks.md has the figures).
  EXPECT_GT(wire["estimate_to_sync_us"]["count"].get<int>(), 0);

  if (run.peer) {
    // The independent peer saw every SYNC the master counted (candump ran before the master
    // started and after it ended), and the drives' heartbeats (0x700 + node id).
    EXPECT_EQ(drivers::test::count_frames(run.frames, " 080#"),
              can["syncs_sent"].get<std::size_t>());
    EXPECT_GE(drivers::test::count_frames(run.frames, " 702#05"), 1U);
    std::printf("CAN_SMOKE: candump recorded %zu frames\n", run.frames.size());
  } else {
    std::printf("CAN_SMOKE: candump not in the guest: frames not cross-checked\n");
  }
}

TEST_F(CanTwoProcess, ControlAndTwinRunTheLineOverVcan) {
  const VcanRun run = run_line_over_vcan(kWorkDir / "run", kDuration, kRunLimit, environment());
  std::printf("%s", run.logs.c_str());
  ASSERT_EQ(run.control_exit, 0) << run.logs;
  ASSERT_EQ(run.twin_exit, 0) << run.logs;
  expect_a_clean_run(run);
  std::printf("CAN_SMOKE: %s\n", run.control_kpis.dump().c_str());
}

#ifdef FL_CAN_SOAK
// The last `bytes` of a log: ten minutes of the processes' logs are too long for the console.
std::string tail_of(const std::string& log, std::size_t bytes) {
  return log.size() > bytes ? "[...]" + log.substr(log.size() - bytes) : log;
}

// Issue 5's target over the real kernel CAN stack: the two processes for ten minutes against
// the fast plant, KPIs within 1 point of the lock-step run with the same seed and the same
// configuration, computed here in the guest beforehand (under a minute even emulated).
TEST_F(CanTwoProcess, TenMinutesOverVcanMatchTheLockStepRun) {
  const LineConfig line = load_line_config(kWorkDir / "config" / "line.yaml");
  const std::unique_ptr<Plant> plant =
      apps::make_plant("fast", (kWorkDir / "config" / "plant_fast.yaml").string(), line, "");
  apps::RunOptions options;
  options.duration_s = apps::parse_duration_s(kSoakDuration).value();
  options.seed = 1;
  const nlohmann::json reference = apps::to_json(apps::run_closed_loop(line, *plant, options));
  std::printf("CAN_SOAK_LOCK_STEP: %s\n", reference.dump().c_str());
  std::fflush(stdout);

  const VcanRun run =
      run_line_over_vcan(kWorkDir / "soak", kSoakDuration, kSoakRunLimit, environment());
  ASSERT_EQ(run.control_exit, 0) << run.logs;
  ASSERT_EQ(run.twin_exit, 0) << run.logs;
  std::printf("%s", tail_of(run.logs, 4096).c_str());
  std::printf("CAN_SOAK_CONTROL: %s\n", run.control_kpis.dump().c_str());
  std::printf("CAN_SOAK_TWIN: %s\n", run.twin_kpis.dump().c_str());
  expect_a_clean_run(run);

  const double in_spec = run.twin_kpis["in_spec_share_of_singulated"].get<double>();
  const double in_spec_ref = reference["in_spec_share_of_singulated"].get<double>();
  EXPECT_NEAR(in_spec, in_spec_ref, kInSpecTolerance);
  const double placed = run.twin_kpis["placed_per_minute"].get<double>();
  const double placed_ref = reference["placed_per_minute"].get<double>();
  EXPECT_NEAR(placed, placed_ref, kThroughputTolerance * placed_ref);
  const double items = run.control_kpis["items_per_minute"].get<double>();
  const double items_ref = reference["items_per_minute"].get<double>();
  EXPECT_NEAR(items, items_ref, kThroughputTolerance * items_ref);
  std::printf(
      "CAN_SOAK: in spec %.4f (lock step %.4f), placed/min %.2f (%.2f), items/min %.2f "
      "(%.2f), overruns %d\n",
      in_spec, in_spec_ref, placed, placed_ref, items, items_ref,
      run.control_kpis["runtime"]["overruns"].get<int>());
}
#endif

// A twin that dies mid-run is every device going silent at once: the master's heartbeat
// consumer loses each node within its timeout, the line faults and stops, and the ledger
// closes what was on the belts as lost, nothing dropped (exit 4: the peer was lost).
TEST_F(CanTwoProcess, ControllerFaultsWhenTheDevicesFallSilent) {
  const fs::path dir = kWorkDir / "devices_lost";
  const RunningPair run = start_pair(dir, environment());
  const int control_exit = kill_and_wait(run.twin, run.control);
  const std::string logs = "--- control\n" + text(dir / "control.log");
  std::printf("%s", logs.c_str());
  ASSERT_EQ(control_exit, 4) << logs;

  const nlohmann::json result = load(dir / "control.json");
  EXPECT_TRUE(result["runtime"]["line_faulted"].get<bool>());
  EXPECT_GT(result["can"]["nodes_lost"].get<int>(), 0);
  // Each lost node went out on fl/line/faults, and the line's own fault with them.
  EXPECT_GT(result["dds"]["fault_reports_published"].get<int>(),
            result["can"]["nodes_lost"].get<int>());
  EXPECT_TRUE(result["ledger"]["balanced"].get<bool>());
  EXPECT_EQ(result["ledger"]["records_dropped"].get<int>(), 0);
  EXPECT_GT(result["ledger"]["items_created"].get<int>(), 0);
}

// A controller that dies mid-run stops sending SYNC and its heartbeat. Every emulated device was
// told at start-up to watch that heartbeat (can.yaml master); when it runs out each stops on
// its own (drives quick-stop, modules switch their outputs off), as real devices would, and the
// twin reports the controller lost (exit 4) with every fillet it fed accounted for.
TEST_F(CanTwoProcess, TwinStopsTheBeltsWhenTheMasterFallsSilent) {
  const fs::path dir = kWorkDir / "master_lost";
  const RunningPair run = start_pair(dir, environment());
  const int twin_exit = kill_and_wait(run.control, run.twin);
  const std::string logs = "--- twin\n" + text(dir / "twin.log");
  std::printf("%s", logs.c_str());
  ASSERT_EQ(twin_exit, 4) << logs;

  const nlohmann::json result = load(dir / "twin.json");
  EXPECT_TRUE(result["twin"]["controller_lost"].get<bool>());
  EXPECT_GT(result["twin"]["stale_ticks"].get<int>(), 0);
  // All 13 drives and 3 modules: the belts stopped because the devices did.
  EXPECT_EQ(result["twin"]["can"]["devices_that_lost_the_master"].get<int>(),
            static_cast<int>(kDriveCount + drivers::kIoModuleCount));
  EXPECT_TRUE(result["truth"]["balanced"].get<bool>());
  EXPECT_GT(result["truth"]["on_line_at_end"].get<int>(), 0);  // stopped, not emptied
}

}  // namespace
}  // namespace fl

static int checked_main(int argc, char** argv) {
  if (argc > 1 && (std::strcmp(argv[1], "control") == 0 || std::strcmp(argv[1], "twin") == 0)) {
    CLI::App app{"linectl's two-process commands, for the CAN smoke test in the qemu guest"};
    app.require_subcommand(1);
    fl::apps::TwinServeArgs twin_args;
    CLI::App* twin = fl::apps::add_twin_subcommand(app, twin_args);
    fl::apps::ControlArgs control_args;
    CLI::App* control = fl::apps::add_control_subcommand(app, control_args);
    CLI11_PARSE(app, argc, argv);
    try {
      if (control->parsed()) return fl::apps::control_command(control_args);
      if (twin->parsed()) return fl::apps::twin_serve_command(twin_args);
    } catch (const std::exception& error) {
      spdlog::error("{}", error.what());
      return 1;
    }
    return 2;
  }
  ::testing::InitGoogleTest(&argc, argv);
#ifdef FL_CAN_SOAK
  // The guest's init runs it without arguments: the soak is this binary's only test.
  ::testing::GTEST_FLAG(filter) = "CanTwoProcess.TenMinutesOverVcanMatchTheLockStepRun";
#endif
  return RUN_ALL_TESTS();
}

int main(int argc, char** argv) {
  // What escapes the commands' own handling (an option table that throws, memory): a message
  // and exit status 1 instead of std::terminate.
  try {
    return checked_main(argc, argv);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "can_two_process_smoke: %s\n", error.what());
  } catch (...) {
    std::fprintf(stderr, "can_two_process_smoke: unknown error\n");
  }
  return 1;
}
