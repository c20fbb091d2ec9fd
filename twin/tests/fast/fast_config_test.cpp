// config/plant_fast.yaml equals FastPlantConfig's defaults, and the loader is strict.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "fl/controller/yaml_reader.hpp"
#include "fl/twin/fast_plant_config.hpp"

namespace fl::test {
namespace {

const std::filesystem::path kYaml = std::filesystem::path(FL_SOURCE_DIR) / "config/plant_fast.yaml";

std::string read_text(const std::filesystem::path& file) {
  std::ifstream stream(file);
  std::stringstream text;
  text << stream.rdbuf();
  return text.str();
}

// Writes `text` to a file in the test's temporary directory.
std::filesystem::path write_temp(const std::string& name, const std::string& text) {
  auto path = std::filesystem::temp_directory_path() / name;
  std::ofstream(path) << text;
  return path;
}

// Replaces the first occurrence of `from` in `text`.
std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

std::vector<ConfigProblem> problems_of(const std::filesystem::path& file) {
  try {
    (void)load_fast_plant_config(file);
  } catch (const ConfigError& error) {
    return error.problems();
  }
  return {};
}

TEST(FastPlantConfigFile, EqualsTheDefaults) {
  const FastPlantConfig loaded = load_fast_plant_config(kYaml);
  const FastPlantConfig defaults;
  EXPECT_TRUE(loaded == defaults);
  // Spot checks that say which part differs if the comparison above fails.
  EXPECT_TRUE(loaded.fillet == defaults.fillet);
  EXPECT_TRUE(loaded.infeed == defaults.infeed);
  EXPECT_TRUE(loaded.belts == defaults.belts);
  EXPECT_TRUE(loaded.multilane == defaults.multilane);
  for (std::size_t c = 0; c < kCameraCount; ++c) {
    EXPECT_TRUE(loaded.cameras[c] == defaults.cameras[c]) << "camera " << c;
  }
}

TEST(FastPlantConfigFile, UnknownKeyIsRefusedWithFileKeyAndLine) {
  const std::string text = replaced(read_text(kYaml), "  mu_belt: 0.4", "  mu_blet: 0.4");
  const auto file = write_temp("plant_fast_unknown_key.yaml", text);
  const auto problems = problems_of(file);
  ASSERT_FALSE(problems.empty());
  bool unknown = false;
  bool missing = false;
  for (const ConfigProblem& problem : problems) {
    EXPECT_NE(problem.file.find("plant_fast_unknown_key.yaml"), std::string::npos);
    if (problem.kind == ProblemKind::kUnknownKey) {
      unknown = true;
      EXPECT_EQ(problem.key_path, "belts.mu_blet");
      EXPECT_GT(problem.line, 0);
    }
    if (problem.kind == ProblemKind::kMissingKey) {
      missing = true;
      EXPECT_EQ(problem.key_path, "belts.mu_belt");
    }
  }
  EXPECT_TRUE(unknown);
  EXPECT_TRUE(missing);
}

TEST(FastPlantConfigFile, OutOfRangeWrongTypeAndInconsistentValuesAreAllReported) {
  std::string text = read_text(kYaml);
  text = replaced(text, "touching_pair_prob: 0.04", "touching_pair_prob: 1.5");
  text = replaced(text, "    classifies: true", "    classifies: \"yes\"");
  text = replaced(text, "flow_opening_mm: 60.0", "flow_opening_mm: 40.0");
  const auto file = write_temp("plant_fast_bad_values.yaml", text);
  const auto problems = problems_of(file);
  bool range = false;
  bool type = false;
  bool inconsistent = false;
  for (const ConfigProblem& problem : problems) {
    range |= problem.kind == ProblemKind::kOutOfRange &&
             problem.key_path == "fillets.touching_pair_prob" && problem.line > 0;
    type |= problem.kind == ProblemKind::kWrongType &&
            problem.key_path == "cameras.orientation.classifies";
    inconsistent |=
        problem.kind == ProblemKind::kInconsistent && problem.key_path == "infeed.block_opening_mm";
  }
  EXPECT_TRUE(range);
  EXPECT_TRUE(type);
  EXPECT_TRUE(inconsistent);
}

TEST(FastPlantConfigFile, WrongNumberOfSizeVariantsIsRefused) {
  const std::string text = replaced(
      read_text(kYaml), "    - {length_mm: 176.0, width_mm: 72.0, thickness_mm: 40.0}\n", "");
  const auto problems = problems_of(write_temp("plant_fast_variants.yaml", text));
  ASSERT_EQ(problems.size(), 1U);
  EXPECT_EQ(problems[0].key_path, "fillets.variants");
  EXPECT_EQ(problems[0].kind, ProblemKind::kInvalidValue);
}

TEST(FastPlantConfigFile, MissingFileIsReported) {
  const auto problems = problems_of("/nonexistent/plant_fast.yaml");
  ASSERT_EQ(problems.size(), 1U);
  EXPECT_EQ(problems[0].kind, ProblemKind::kFile);
}

}  // namespace
}  // namespace fl::test
