// Loading measured datasets: the example loads in SI; every malformed manifest, file, column,
// unit and value is reported with its file, line and column, and nothing partial is returned.
#include "fl/workbench/dataset.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numbers>
#include <random>
#include <string>
#include <typeinfo>
#include <utility>
#include <vector>

namespace fl::workbench {
namespace {

namespace fs = std::filesystem;

// A dataset folder written by the test, removed afterwards.
class DatasetFolder {
 public:
  DatasetFolder() {
    path_ = fs::temp_directory_path() /
            ("fl_workbench_" +
             std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~DatasetFolder() { fs::remove_all(path_); }
  DatasetFolder(const DatasetFolder&) = delete;
  DatasetFolder& operator=(const DatasetFolder&) = delete;

  void write(const std::string& name, const std::string& text) const {
    std::ofstream(path_ / name, std::ios::binary) << text;
  }
  [[nodiscard]] const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

std::string manifest(const std::string& experiment, const std::string& conditions,
                     const std::string& trials) {
  return "format: fillet-measurements/1\nname: test\nexperiment: " + experiment + "\n" +
         conditions + "trials:\n" + trials;
}

const std::string kOneTrial = "  - id: a\n    file: a.csv\n";
const std::string kRate = "conditions:\n  rate: 1 mm/s\n";

// The problems of loading `folder`; fails the test when it loads.
std::vector<DatasetProblem> problems_of(const fs::path& folder) {
  try {
    (void)load_dataset(folder);
  } catch (const DatasetError& error) {
    return error.problems();
  }
  ADD_FAILURE() << folder << " loaded, a problem was expected";
  return {};
}

// True when some problem is in `file_suffix` at `line` (0: any) and says `fragment`.
::testing::AssertionResult has_problem(const std::vector<DatasetProblem>& problems,
                                       const std::string& file_suffix, int line,
                                       const std::string& fragment) {
  std::string all;
  for (const DatasetProblem& p : problems) {
    all += "\n  " + p.to_string();
    const bool file_ok =
        p.file.size() >= file_suffix.size() &&
        p.file.compare(p.file.size() - file_suffix.size(), file_suffix.size(), file_suffix) == 0;
    if (file_ok && (line == 0 || p.line == line) && p.message.find(fragment) != std::string::npos) {
      return ::testing::AssertionSuccess();
    }
  }
  return ::testing::AssertionFailure() << "no problem in " << file_suffix << ":" << line
                                       << " saying '" << fragment << "'; got:" << all;
}

TEST(Dataset, ExampleLoadsInSiUnits) {
  const Dataset data = load_dataset(fs::path(FL_WORKBENCH_TEST_DATA) / "compress_example");
  EXPECT_EQ(data.experiment, ExperimentType::kCompress);
  EXPECT_EQ(data.name, "compress example");
  ASSERT_EQ(data.trials.size(), 2U);
  const Trial& slow = data.trials[0];
  ASSERT_EQ(slow.data.rows(), 4U);
  // 3 mm at line 6 of the file (a comment and the header come first).
  EXPECT_DOUBLE_EQ(slow.data.at("displacement").values_si[3], 3e-3);
  EXPECT_EQ(slow.data.lines[3], 6);
  EXPECT_EQ(slow.data.at("force").unit.symbol, "N");
  // 1 mm/s from the dataset's conditions; the fast trial overrides it with 5 mm/s.
  EXPECT_DOUBLE_EQ(std::get<double>(slow.conditions.at("rate")), 1e-3);
  const Trial& fast = data.trials[1];
  EXPECT_DOUBLE_EQ(std::get<double>(fast.conditions.at("rate")), 5e-3);
  EXPECT_DOUBLE_EQ(std::get<double>(fast.conditions.at("hold")), 2.0);
  EXPECT_EQ(std::get<std::string>(fast.conditions.at("variant")), "172x72x32");
  // The fast file is in milliseconds with CRLF line ends: 2400 ms is 2.4 s.
  EXPECT_DOUBLE_EQ(fast.data.at("time").values_si.back(), 2.4);
  EXPECT_DOUBLE_EQ(data.noise_si.at("force"), 0.02);
  EXPECT_DOUBLE_EQ(data.noise_si.at("displacement"), 10e-6);
  EXPECT_THROW((void)slow.data.at("torque"), std::out_of_range);
}

TEST(Dataset, MissingFolderOrManifest) {
  EXPECT_TRUE(
      has_problem(problems_of("/nonexistent/dataset"), "/nonexistent/dataset", 0, "not a folder"));
  const DatasetFolder folder;
  EXPECT_TRUE(has_problem(problems_of(folder.path()), "manifest.yaml", 0, "cannot"));
}

TEST(Dataset, ManifestProblemsNameTheLine) {
  const DatasetFolder folder;
  // Line 1 format, 3 experiment; all problems at once.
  folder.write("manifest.yaml",
               "format: fillet-measurements/2\nname: x\nexperiment: compression\n"
               "trials:\n" +
                   kOneTrial);
  const auto problems = problems_of(folder.path());
  EXPECT_TRUE(has_problem(problems, "manifest.yaml", 1, "is not fillet-measurements/1"));
  EXPECT_TRUE(has_problem(problems, "manifest.yaml", 3, "'compression' is not one of slide"));
}

TEST(Dataset, ConditionsNeedTheirQuantityAndRange) {
  const DatasetFolder folder;
  folder.write("a.csv", "time [s],displacement [mm],force [N]\n0,0,0\n");
  // Line 5: a force where a speed belongs; line 6: a bare number; line 7: a typo'd key.
  folder.write(
      "manifest.yaml",
      manifest("compress", "conditions:\n  rate: 2 N\n  hold: 3\n  rat: 1 mm/s\n  surface: damp\n",
               kOneTrial));
  const auto problems = problems_of(folder.path());
  EXPECT_TRUE(has_problem(problems, "manifest.yaml", 5, "'2 N' is not a speed"));
  EXPECT_TRUE(has_problem(problems, "manifest.yaml", 6, "'3' is not a time"));
  EXPECT_TRUE(has_problem(problems, "manifest.yaml", 7, "unknown key"));
  EXPECT_TRUE(has_problem(problems, "manifest.yaml", 8, "'damp' is not one of dry, wet"));
}

TEST(Dataset, ASlidesPlacementIsRelaidOrLaidOnce) {
  const DatasetFolder folder;
  folder.write("a.csv", "onset_angle [deg]\n30.1\n29.8\n");
  // Line 5: how a lab might write "turned a little each time"; diagnose could not tell.
  folder.write("manifest.yaml",
               manifest("slide", "conditions:\n  placement: sideways\n", kOneTrial));
  EXPECT_TRUE(has_problem(problems_of(folder.path()), "manifest.yaml", 5,
                          "'sideways' is not one of relaid, laid_once"));
  folder.write("manifest.yaml", manifest("slide", "conditions:\n  placement: relaid\n", kOneTrial));
  const Dataset loaded = load_dataset(folder.path());
  EXPECT_EQ(std::get<std::string>(loaded.trials[0].conditions.at("placement")), "relaid");
}

TEST(Dataset, RequiredConditionMayComeFromEitherLevelButMustCome) {
  const DatasetFolder folder;
  folder.write("a.csv", "time [s],displacement [mm],force [N]\n0,0,0\n");
  folder.write("manifest.yaml", manifest("compress", "", kOneTrial));
  // Line 5: the trial lacking it (line 4 is "trials:").
  EXPECT_TRUE(has_problem(problems_of(folder.path()), "manifest.yaml", 5,
                          "trial 'a' has no condition 'rate'"));
  folder.write("manifest.yaml",
               manifest("compress", "", kOneTrial + "    conditions:\n      rate: 2 mm/s\n"));
  EXPECT_NO_THROW((void)load_dataset(folder.path()));
  // 2 m/s is beyond the 1 m/s a compression test machine reaches: out of range.
  folder.write("manifest.yaml", manifest("compress", "conditions:\n  rate: 2 m/s\n", kOneTrial));
  EXPECT_TRUE(has_problem(problems_of(folder.path()), "manifest.yaml", 5, "out of range"));
}

// A bulk-flow hopper fed while it runs: a rate of fillets, in any rate unit.
TEST(Dataset, BulkFlowFeedRateIsARate) {
  const DatasetFolder folder;
  folder.write("a.csv", "opening [mm],outflow [kg/s]\n50,0.4\n");
  folder.write("manifest.yaml",
               manifest("bulk_flow", "conditions:\n  feed_rate: 180 1/min\n", kOneTrial));
  const Dataset data = load_dataset(folder.path());
  EXPECT_DOUBLE_EQ(std::get<double>(data.trials.front().conditions.at("feed_rate")), 3.0);
  // A length is not a rate.
  folder.write("manifest.yaml",
               manifest("bulk_flow", "conditions:\n  feed_rate: 3 mm\n", kOneTrial));
  EXPECT_TRUE(has_problem(problems_of(folder.path()), "manifest.yaml", 5, "is not a rate"));
  // 30 a second is beyond the 20 the schema allows (four times the line's supply).
  folder.write("manifest.yaml",
               manifest("bulk_flow", "conditions:\n  feed_rate: 30 1/s\n", kOneTrial));
  EXPECT_TRUE(has_problem(problems_of(folder.path()), "manifest.yaml", 5, "out of range"));
}

// A slide rig's tilt rate: an angular speed in either unit, refused as an angle or beyond the
// slow tilt the test means.
TEST(Dataset, SlideTiltRateIsAnAngularSpeed) {
  const DatasetFolder folder;
  folder.write("a.csv", "onset_angle [deg]\n31.5\n");
  folder.write("manifest.yaml",
               manifest("slide", "conditions:\n  tilt_rate: 2 deg/s\n", kOneTrial));
  const Dataset data = load_dataset(folder.path());
  EXPECT_DOUBLE_EQ(std::get<double>(data.trials.front().conditions.at("tilt_rate")),
                   2.0 * std::numbers::pi / 180.0);
  folder.write("manifest.yaml", manifest("slide", "conditions:\n  tilt_rate: 2 deg\n", kOneTrial));
  EXPECT_TRUE(
      has_problem(problems_of(folder.path()), "manifest.yaml", 5, "is not an angular speed"));
  // 2 rad/s (115 deg/s) is beyond the 90 deg/s the schema allows: a flung fillet, not a slide.
  folder.write("manifest.yaml",
               manifest("slide", "conditions:\n  tilt_rate: 2 rad/s\n", kOneTrial));
  EXPECT_TRUE(has_problem(problems_of(folder.path()), "manifest.yaml", 5, "out of range"));
}

TEST(Dataset, DuplicateTrialIdsAndNoTrials) {
  const DatasetFolder folder;
  folder.write("a.csv", "time [s],displacement [mm],force [N]\n0,0,0\n");
  folder.write("manifest.yaml", manifest("compress", kRate, kOneTrial + kOneTrial));
  EXPECT_TRUE(has_problem(problems_of(folder.path()), "manifest.yaml", 0, "used twice"));
  folder.write("manifest.yaml", manifest("compress", kRate, "  []\n"));
  EXPECT_TRUE(has_problem(problems_of(folder.path()), "manifest.yaml", 0, "no trials"));
}

TEST(Dataset, HeaderProblems) {
  const DatasetFolder folder;
  folder.write("manifest.yaml", manifest("compress", kRate, kOneTrial));
  const auto header = [&](const std::string& line) {
    folder.write("a.csv", line + "\n0,0,0\n");
    return problems_of(folder.path());
  };
  EXPECT_TRUE(has_problem(header("time [s],displacement,force [N]"), "a.csv", 1,
                          "'displacement' has no unit"));
  EXPECT_TRUE(has_problem(header("time [s],displacement [mm],force [lbf]"), "a.csv", 1,
                          "unknown unit 'lbf' (a force: use one of N, mN, kN)"));
  EXPECT_TRUE(has_problem(header("time [s],displacement [N],force [N]"), "a.csv", 1,
                          "'N' is a unit of force, the column is a length"));
  EXPECT_TRUE(has_problem(header("time [s],displacement [mm],forse [N]"), "a.csv", 1,
                          "unknown column 'forse'"));
  EXPECT_TRUE(
      has_problem(header("time [s],displacement [mm],time [s]"), "a.csv", 1, "appears twice"));
  EXPECT_TRUE(has_problem(header("time [s],displacement [mm]"), "a.csv", 1,
                          "required column 'force' is missing"));
}

TEST(Dataset, ABadHeaderHidesNoProblemOfTheRows) {
  // Found by an audit: a column with an unknown unit stopped the file's checks there, so the
  // NaN and the negative time below went unreported, and the column was reported missing too.
  const DatasetFolder folder;
  folder.write("manifest.yaml", manifest("compress", kRate, kOneTrial));
  folder.write("a.csv", "time [s],displacement [furlong],force [N]\n0,0,0\n0.1,nan,0.2\n-1,0,0\n");
  const auto problems = problems_of(folder.path());
  EXPECT_TRUE(has_problem(problems, "a.csv", 1, "unknown unit 'furlong'"));
  EXPECT_TRUE(has_problem(problems, "a.csv", 3, "displacement: 'nan' is not finite"));
  EXPECT_TRUE(has_problem(problems, "a.csv", 4, "time: -1 s is out of range"));
  for (const DatasetProblem& problem : problems) {
    EXPECT_EQ(problem.message.find("is missing"), std::string::npos) << problem.to_string();
  }
}

TEST(Dataset, CellProblemsNameLineAndColumn) {
  const DatasetFolder folder;
  folder.write("manifest.yaml", manifest("compress", kRate, kOneTrial));
  // Line 3: text; 4: NaN; 5: short row; 6: an empty cell; 8: time going back; 9: 5 m of
  // displacement (a file written in m where mm was meant), beyond the 0.2 m range.
  folder.write("a.csv",
               "time [s],displacement [mm],force [N]\n0,0,0\n1,abc,0\n2,0,nan\n3,0\n4,,0\n"
               "5,0,0\n4.5,0,0\n6,5000,0\n");
  const auto problems = problems_of(folder.path());
  EXPECT_TRUE(has_problem(problems, "a.csv", 3, "displacement: 'abc' is not a number"));
  EXPECT_TRUE(has_problem(problems, "a.csv", 4, "force: 'nan' is not finite"));
  EXPECT_TRUE(has_problem(problems, "a.csv", 5, "2 fields, the header has 3"));
  EXPECT_TRUE(has_problem(problems, "a.csv", 6, "empty cell"));
  EXPECT_TRUE(has_problem(problems, "a.csv", 9, "5000 mm is out of range [-200 mm, 200 mm]"));
  EXPECT_TRUE(has_problem(problems, "a.csv", 8, "does not increase (line 7 had 5 s)"));
  for (const DatasetProblem& p : problems) {
    if (p.line == 3) {
      EXPECT_EQ(p.column, 2);  // the displacement field
    }
  }
}

TEST(Dataset, CompressionWrittenNegativeIsRefusedNotRunAsALiftOff) {
  const DatasetFolder folder;
  folder.write("manifest.yaml", manifest("compress", kRate, kOneTrial));
  const std::string header = "time [s],displacement [mm],force [N]\n";
  // A machine that records compression negative: the force peaks 1.5 mm "up". Run as it
  // stands the twin's plate would leave the sample and answer 0 N at every row.
  folder.write("a.csv", header + "0,0,0\n1,-0.5,2\n2,-1.5,6\n");
  EXPECT_TRUE(has_problem(problems_of(folder.path()), "a.csv", 4,
                          "below its first value (0 mm), and it never rises more than 0 mm"));
  // The same with 1 um of noise lifting one row above the start: 1 um against 1.5 mm.
  folder.write("a.csv", header + "0,0,0\n1,0.001,0\n2,-0.5,2\n3,-1.5,6\n");
  EXPECT_TRUE(has_problem(problems_of(folder.path()), "a.csv", 5, "compression is positive"));
  // Loaded, each way the review of the first rule found refused:
  const auto loads = [&](const std::string& rows) {
    folder.write("a.csv", header + rows);
    EXPECT_NO_THROW((void)load_dataset(folder.path())) << rows;
  };
  loads("0,12.5,0\n1,13,2\n2,14,6\n");               // an absolute crosshead position
  loads("0,0,0\n1,1,4\n2,-0.001,0\n");               // unloaded 1 um past the start (noise)
  loads("0,0,0\n1,1,4\n2,0,0\n3,-11,0\n");           // unloaded, then back home 11 mm up
  loads("0,0,0.5\n1,-2,0\n2,0,0.5\n3,0.15,2\n");     // a pre-load, a 2 mm back-off, 0.15 mm in
  loads("0,0,1\n1,0,1.02\n2,-0.001,0.98\n3,0,1\n");  // a still plate, 1 um of jitter
}

TEST(Dataset, FileProblems) {
  const DatasetFolder folder;
  folder.write("manifest.yaml", manifest("compress", kRate, kOneTrial));
  EXPECT_TRUE(has_problem(problems_of(folder.path()), "a.csv", 0, "cannot open"));
  folder.write("a.csv", "");
  EXPECT_TRUE(has_problem(problems_of(folder.path()), "a.csv", 0, "no header row"));
  folder.write("a.csv", "time [s],displacement [mm],force [N]\n");
  EXPECT_TRUE(has_problem(problems_of(folder.path()), "a.csv", 1, "no data rows"));
  folder.write("a.csv", std::string("time [s],displacement [mm],force [N]\n0,0\0,0\n", 44));
  EXPECT_TRUE(has_problem(problems_of(folder.path()), "a.csv", 2, "binary data"));
  folder.write("a.csv", "time [s],displacement [mm],force [N]\n0,\"0,0\n");
  EXPECT_TRUE(has_problem(problems_of(folder.path()), "a.csv", 2, "not closed"));
}

TEST(Dataset, EveryBrokenFileIsReportedAndTheListIsCapped) {
  const DatasetFolder folder;
  folder.write("manifest.yaml",
               manifest("compress", kRate, kOneTrial + "  - id: b\n    file: b.csv\n"));
  // A semicolon-separated export: one field per line, so every data line is a problem.
  std::string semicolons = "time [s];displacement [mm];force [N]\n";
  for (int k = 0; k < 100; ++k) semicolons += std::to_string(k) + ";0;0\n";
  folder.write("a.csv", semicolons);
  folder.write("b.csv", "time [s],displacement [mm],force [N]\n0,x,0\n");
  const auto problems = problems_of(folder.path());
  EXPECT_TRUE(has_problem(problems, "a.csv", 0, "unknown unit"));
  EXPECT_TRUE(has_problem(problems, "b.csv", 2, "not a number"));

  std::string short_rows = "time [s],displacement [mm],force [N]\n";
  for (int k = 0; k < 100; ++k) short_rows += std::to_string(k) + ",0\n";
  folder.write("a.csv", short_rows);
  const auto capped = problems_of(folder.path());
  std::size_t in_a = 0;
  for (const DatasetProblem& p : capped) in_a += p.file.ends_with("a.csv") ? 1 : 0;
  // 25 listed and one line counting the other 75: the file's problems stay readable.
  EXPECT_EQ(in_a, 26U);
  EXPECT_TRUE(has_problem(capped, "a.csv", 0, "75 more problems"));
}

TEST(Dataset, LineTracksOrderTimePerFilletAndReadTheCommandLog) {
  const DatasetFolder folder;
  folder.write(
      "manifest.yaml",
      manifest("line_tracks", "", "  - id: run1\n    file: tracks.csv\n    commands: belts.csv\n"));
  // Two fillets interleaved: time rises per fillet, not over the file.
  folder.write("tracks.csv",
               "time [s],fillet [1],x [mm],y [mm],angle [deg]\n0.00,1,100,5,90\n0.00,2,0,-3,45\n"
               "0.04,1,116,5,88\n0.04,2,16,-3,44\n");
  folder.write("belts.csv", "time [s],takt [m/s],multilane_left [mm/s]\n0,0.4,400\n0.5,0.5,420\n");
  const Dataset data = load_dataset(folder.path());
  ASSERT_EQ(data.trials.size(), 1U);
  const Trial& run = data.trials[0];
  EXPECT_DOUBLE_EQ(run.data.at("angle").values_si[2], 88.0 * std::numbers::pi / 180.0);
  ASSERT_TRUE(run.commands.has_value());
  EXPECT_DOUBLE_EQ(run.commands->at("multilane_left").values_si[1], 0.42);

  // A fillet number must be whole; a command column must be a speed.
  folder.write("tracks.csv", "time [s],fillet [1],x [mm],y [mm],angle [deg]\n0,1.5,0,0,0\n");
  folder.write("belts.csv", "time [s],takt [mm]\n0,1\n");
  const auto problems = problems_of(folder.path());
  EXPECT_TRUE(has_problem(problems, "tracks.csv", 2, "not a whole number"));
  EXPECT_TRUE(
      has_problem(problems, "belts.csv", 1, "'mm' is a unit of length, the column is a speed"));

  // A fillet going back in time.
  folder.write("tracks.csv",
               "time [s],fillet [1],x [mm],y [mm],angle [deg]\n0.04,1,0,0,0\n0.00,2,0,0,0\n"
               "0.00,1,0,0,0\n");
  folder.write("belts.csv", "time [s],takt [m/s]\n0,0.4\n");
  EXPECT_TRUE(
      has_problem(problems_of(folder.path()), "tracks.csv", 4, "does not increase for fillet 1"));
}

TEST(Dataset, ALineLogNamesEveryBeltAndItsStationsAreOnOrOff) {
  const DatasetFolder folder;
  folder.write("manifest.yaml",
               manifest("line_tracks", "conditions:\n  machine: line\n",
                        "  - id: run1\n    file: tracks.csv\n    commands: line.csv\n"));
  folder.write("tracks.csv", "time [s],fillet [1],x [mm],y [mm],angle [deg]\n0,1,2900,0,0\n");
  // Every belt from the takt to the outfeed, by its drive name; the bulk belt is upstream of the
  // path and not asked for.
  const std::string belts =
      "time [s],takt [m/s],transition1 [m/s],transition2 [m/s],guide [m/s],reject [m/s],"
      "centring [m/s],multilane1_left [m/s],multilane1_right [m/s],multilane2_left [m/s],"
      "multilane2_right [m/s],squeeze [m/s],outfeed [m/s]";
  const std::string speeds = "0,0.12,0.3,0.45,0.5,0.5,0.5,0.68,0.52,0.68,0.52,0.5,0.5";
  folder.write("line.csv", belts + ",flip_plate1 [1],centring_shift [mm]\n" + speeds + ",0,-12\n" +
                               "0.5," + speeds.substr(2) + ",1,-12\n");
  const Dataset data = load_dataset(folder.path());
  ASSERT_TRUE(data.trials[0].commands.has_value());
  EXPECT_TRUE(runs_on_line(data.trials[0].conditions));
  EXPECT_DOUBLE_EQ(data.trials[0].commands->at("centring_shift").values_si[0], -0.012);
  EXPECT_DOUBLE_EQ(data.trials[0].commands->at("flip_plate1").values_si[1], 1.0);

  // A belt left out would run at a guessed speed; a name the line does not have is listed with
  // the ones it has; a station is off (0) or on (1), nothing between.
  folder.write("line.csv", "time [s],takt [m/s],conveyor9 [m/s],flip_plate2 [1]\n0,0.1,0.2,2\n");
  auto problems = problems_of(folder.path());
  EXPECT_TRUE(has_problem(problems, "line.csv", 1, "required column 'multilane2_right'"));
  EXPECT_TRUE(has_problem(problems, "line.csv", 1,
                          "unknown column 'conveyor9' for a line's command log (machine: line)"));
  folder.write("line.csv", belts + ",flip_plate2 [1]\n" + speeds + ",2\n");
  EXPECT_TRUE(
      has_problem(problems_of(folder.path()), "line.csv", 2, "flip_plate2: '2' is not 0 or 1"));

  // Tracks on the line without the log that drove it cannot be replayed.
  folder.write("manifest.yaml", manifest("line_tracks", "conditions:\n  machine: line\n",
                                         "  - id: run1\n    file: tracks.csv\n"));
  // Line 7: the trial, after two lines of conditions and "trials:".
  EXPECT_TRUE(has_problem(problems_of(folder.path()), "manifest.yaml", 7,
                          "ran on the line (machine: line) and names no command log"));
  folder.write("manifest.yaml", manifest("line_tracks", "conditions:\n  machine: plant\n",
                                         "  - id: run1\n    file: tracks.csv\n"));
  EXPECT_TRUE(has_problem(problems_of(folder.path()), "manifest.yaml", 0, "'plant' is not one of"));
}

// Malformed files of every kind the loader reads (manifest, data CSV, line log), made by
// mutating valid ones: each either loads or is refused with DatasetError naming a file; nothing
// else escapes. Deterministic (seed 7), 1500 cases; the sanitizer run checks the memory too.
TEST(Dataset, MutatedFilesAreLoadedOrRefusedNeverAnythingElse) {
  const DatasetFolder folder;
  const std::string belts =
      "time [s],takt [m/s],transition1 [m/s],transition2 [m/s],guide [m/s],reject [m/s],"
      "centring [m/s],multilane1_left [m/s],multilane1_right [m/s],multilane2_left [m/s],"
      "multilane2_right [m/s],squeeze [m/s],outfeed [m/s],flip_plate1 [1]\n"
      "0,0.12,0.3,0.45,0.5,0.5,0.5,0.68,0.52,0.68,0.52,0.5,0.5,0\n"
      "0.5,0.12,0.3,0.45,0.5,0.5,0.5,0.68,0.52,0.68,0.52,0.5,0.5,1\n";
  const std::vector<std::pair<std::string, std::string>> valid{
      {"manifest.yaml", manifest("line_tracks", "conditions:\n  machine: line\n  surface: wet\n",
                                 "  - id: run1\n    file: tracks.csv\n    commands: line.csv\n")},
      {"tracks.csv",
       "time [s],fillet [1],x [mm],y [mm],angle [deg]\n0,1,2900,0,0\n0.025,1,2912,0.5,1\n"
       "0.05,2,2950,-3,170\n"},
      {"line.csv", belts}};
  // Characters a broken export or a hand edit puts in: separators, units, signs, quotes, line
  // ends, YAML syntax, a NUL.
  const std::string alphabet = std::string("0123456789.,-+e[]:# \"'\r\n\t{}nafiNAm/sdeg") + '\0';
  std::mt19937 random(7);
  int refused = 0;
  for (int trial = 0; trial < 1500; ++trial) {
    const std::size_t target = random() % valid.size();
    for (std::size_t f = 0; f < valid.size(); ++f) {
      std::string text = valid[f].second;
      if (f == target) {
        const int edits = 1 + static_cast<int>(random() % 4);
        for (int e = 0; e < edits && !text.empty(); ++e) {
          const std::size_t at = random() % text.size();
          const char c = alphabet[random() % alphabet.size()];
          switch (random() % 3) {
            case 0:
              text[at] = c;
              break;
            case 1:
              text.insert(text.begin() + static_cast<std::ptrdiff_t>(at), c);
              break;
            default:
              text.erase(at, 1 + random() % 8);
              break;
          }
        }
      }
      folder.write(valid[f].first, text);
    }
    try {
      (void)load_dataset(folder.path());
    } catch (const DatasetError& error) {
      ++refused;
      ASSERT_FALSE(error.problems().empty());
      for (const DatasetProblem& problem : error.problems()) {
        ASSERT_FALSE(problem.file.empty()) << problem.to_string();
        ASSERT_FALSE(problem.message.empty());
      }
    } catch (const std::exception& error) {
      FAIL() << "case " << trial << ": " << typeid(error).name() << ": " << error.what();
    }
  }
  // Most single edits of a strict format break it; some (a digit for a digit) do not.
  EXPECT_GT(refused, 500);
  EXPECT_LT(refused, 1500);
}

TEST(Dataset, EveryExperimentHasASchema) {
  for (const ExperimentType type :
       {ExperimentType::kSlide, ExperimentType::kBend, ExperimentType::kSettle,
        ExperimentType::kDrop, ExperimentType::kCompress, ExperimentType::kLineTracks,
        ExperimentType::kBulkFlow}) {
    const ExperimentSchema& schema = schema_of(type);
    EXPECT_EQ(schema.type, type);
    EXPECT_FALSE(schema.columns.empty()) << to_string(type);
    EXPECT_EQ(experiment_from_string(to_string(type)), type);
  }
}

}  // namespace
}  // namespace fl::workbench
