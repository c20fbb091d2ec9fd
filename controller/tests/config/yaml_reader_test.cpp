// The strict YAML reader on small documents: types, ranges, optional keys, unknown and
// duplicate keys, sequences, positions in messages and cross-checks.
// Positions in expected messages ("t.yaml:3:7") are line:column, counted from 1, of the key or
// value the problem is about in that test's text; they are read off the text, not chosen.
#include "fl/controller/yaml_reader.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

namespace fl {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;

enum class Colour : std::uint8_t { kRed, kGreen };
constexpr std::array<EnumName<Colour>, 2> kColours{
    {{"red", Colour::kRed}, {"green", Colour::kGreen}}};

// All problems' messages, one string per problem.
std::vector<std::string> messages(const YamlReader& reader) {
  std::vector<std::string> result;
  for (const ConfigProblem& problem : reader.problems()) {
    result.push_back(problem.to_string());
  }
  return result;
}

TEST(YamlReader, ReadsEveryTypeOfValue) {
  YamlReader reader = YamlReader::from_text(
      "f: 0.85\nd: -1e3\ni: +42\nb: false\ns: \"text\"\ne: green\nhalf: .5\n", "t.yaml");
  {
    YamlMapReader root = reader.root();
    EXPECT_EQ(root.read_float("f", Range::positive()), 0.85F);      // same rounding as the literal
    EXPECT_EQ(root.read_double("d", Range::any()), -1000.0);        // exponent form
    EXPECT_EQ(root.read_int<std::int32_t>("i", Range::any()), 42);  // leading plus sign
    EXPECT_FALSE(root.read_bool("b"));
    EXPECT_EQ(root.read_string("s"), "text");
    EXPECT_EQ(root.read_enum("e", kColours), Colour::kGreen);
    EXPECT_EQ(root.read_float("half", Range::any()), 0.5F);  // no digit before the point
  }
  EXPECT_THAT(messages(reader), IsEmpty());
  EXPECT_NO_THROW(reader.throw_if_problems());
}

TEST(YamlReader, OptionalKeysTakeTheirFallbackOnlyWhenAbsent) {
  YamlReader reader = YamlReader::from_text("present: 2.0\nempty:\n", "t.yaml");
  {
    YamlMapReader root = reader.root();
    // 7.0 and 3: arbitrary fallbacks that differ from anything in the text.
    EXPECT_EQ(root.read_float_or("absent", 7.0F, Range::any()), 7.0F);
    EXPECT_EQ(root.read_int_or<int>("absent_int", 3, Range::any()), 3);
    EXPECT_EQ(root.read_enum_or("absent_colour", Colour::kRed, kColours), Colour::kRed);
    EXPECT_EQ(root.read_float_or("present", 7.0F, Range::any()), 2.0F);  // the file wins
    // An empty value is a mistake, not a request for the fallback.
    EXPECT_EQ(root.read_float_or("empty", 7.0F, Range::any()), 0.0F);  // 0: the placeholder
  }
  EXPECT_THAT(messages(reader),
              ElementsAre("t.yaml:2:1: empty: wrong type: expected a number, found an empty "
                          "value"));  // line 2 column 1: the key, as the value has no position
}

TEST(YamlReader, OptionalPresentValueIsCheckedLikeARequiredOne) {
  YamlReader reader = YamlReader::from_text("gain: -1\n", "t.yaml");
  (void)reader.root().read_float_or("gain", 1.0F, Range::positive());  // -1 is not > 0
  EXPECT_THAT(messages(reader), ElementsAre("t.yaml:1:7: gain: out of range: got -1, must be > 0"));
}

TEST(YamlReader, RangeBounds) {
  // 0 and 1: the bounds themselves, where closed and open intervals differ.
  EXPECT_TRUE(Range::at_least(0.0).contains(0.0));
  EXPECT_FALSE(Range::above(0.0).contains(0.0));
  EXPECT_TRUE(Range::closed(0.0, 1.0).contains(1.0));
  EXPECT_FALSE(Range::open(0.0, 1.0).contains(1.0));
  EXPECT_TRUE(Range::above(0.0).and_at_most(1.0).contains(1.0));
  EXPECT_FALSE(Range::above(0.0).and_at_most(1.0).contains(0.0));
  EXPECT_TRUE(Range::any().contains(-1e300));  // far beyond any configured value
  EXPECT_EQ(Range::above(0.0).and_at_most(180.0).describe(), "in (0, 180]");
  EXPECT_EQ(Range::closed(0.0, 1.0).describe(), "in [0, 1]");
  EXPECT_EQ(Range::positive().describe(), "> 0");
  EXPECT_EQ(Range::below(0.5).describe(), "< 0.5");  // 0.5: prints without trailing digits
}

TEST(YamlReader, DecimalBoundAdmitsTheSameDecimalForAFloat) {
  // 0.1 as float is 0.100000001; the check uses the text's double, so "0.1" <= 0.1 holds.
  YamlReader reader = YamlReader::from_text("x: 0.1\n", "t.yaml");
  EXPECT_EQ(reader.root().read_float("x", Range::at_most(0.1)), 0.1F);
  EXPECT_TRUE(reader.ok());
}

TEST(YamlReader, WrongTypes) {
  YamlReader reader = YamlReader::from_text(
      "quoted: \"0.5\"\n"
      "word: fast\n"
      "yes_no: yes\n"
      "fraction: 3.5\n"
      "block: {a: 1}\n"
      "list: [1, 2]\n"
      "hex: 0x10\n"
      "underscored: 1_000\n"
      "infinite: .inf\n",
      "t.yaml");
  {
    YamlMapReader root = reader.root();
    (void)root.read_float("quoted", Range::any());
    (void)root.read_float("word", Range::any());
    (void)root.read_bool("yes_no");  // YAML 1.1 boolean: refused, only true/false count
    (void)root.read_int<int>("fraction", Range::any());
    (void)root.read_float("block", Range::any());
    (void)root.read_string("list");
    (void)root.read_int<int>("hex", Range::any());
    (void)root.read_double("underscored", Range::any());
    (void)root.read_double("infinite", Range::any());
  }
  EXPECT_THAT(
      messages(reader),
      ElementsAre(
          "t.yaml:1:9: quoted: wrong type: expected a number, found the quoted string \"0.5\" "
          "(write it without quotes)",
          "t.yaml:2:7: word: wrong type: expected a number, found \"fast\"",
          "t.yaml:3:9: yes_no: wrong type: expected true or false, found \"yes\"",
          "t.yaml:4:11: fraction: wrong type: expected an integer, found \"3.5\"",
          "t.yaml:5:8: block: wrong type: expected a number, found a mapping",
          "t.yaml:6:7: list: wrong type: expected a string, found a sequence",
          "t.yaml:7:6: hex: wrong type: expected an integer, found \"0x10\"",
          "t.yaml:8:14: underscored: wrong type: expected a number, found \"1_000\"",
          "t.yaml:9:11: infinite: wrong type: expected a number, found \".inf\""));
}

TEST(YamlReader, IntegerBeyondItsType) {
  // 3000000000 exceeds int32's 2147483647; 300 exceeds uint8's 255.
  YamlReader reader = YamlReader::from_text("big: 3000000000\nbyte: 300\n", "t.yaml");
  {
    YamlMapReader root = reader.root();
    (void)root.read_int<std::int32_t>("big", Range::any());
    (void)root.read_int<std::uint8_t>("byte", Range::any());
  }
  EXPECT_THAT(messages(reader),
              ElementsAre("t.yaml:1:6: big: out of range: got 3000000000, must be in "
                          "[-2147483648, 2147483647] to fit its type",
                          "t.yaml:2:7: byte: out of range: got 300, must be in [0, 255] to fit "
                          "its type"));
}

TEST(YamlReader, FloatOverflowIsOutOfRange) {
  // 1e39 is a fine double but beyond float's largest value, about 3.4e38.
  YamlReader reader = YamlReader::from_text("x: 1e39\n", "t.yaml");
  (void)reader.root().read_float("x", Range::any());
  EXPECT_THAT(messages(reader),
              ElementsAre("t.yaml:1:4: x: out of range: got 1e39, beyond a 32-bit float's range"));
}

TEST(YamlReader, InvalidEnumValueListsTheChoices) {
  YamlReader reader = YamlReader::from_text("colour: Red\n", "t.yaml");
  EXPECT_EQ(reader.root().read_enum("colour", kColours), Colour::kRed);  // placeholder: first
  EXPECT_THAT(messages(reader), ElementsAre("t.yaml:1:9: colour: invalid value: got \"Red\", "
                                            "expected one of: red, green"));
}

TEST(YamlReader, UnknownKeysWithSuggestionAndNestedPath) {
  YamlReader reader =
      YamlReader::from_text("outer:\n  period_s: 1.0\n  perod_s: 2.0\n  zzz: 3\n", "t.yaml");
  {
    YamlMapReader root = reader.root();
    YamlMapReader outer = root.map("outer");
    EXPECT_EQ(outer.read_float("period_s", Range::positive()), 1.0F);  // the value in the text
  }
  EXPECT_THAT(messages(reader),
              ElementsAre("t.yaml:3:3: outer.perod_s: unknown key: not a setting of outer (did "
                          "you mean \"period_s\"?)",
                          "t.yaml:4:3: outer.zzz: unknown key: not a setting of outer"));
}

TEST(YamlReader, MissingKeyAndMissingMappingDoNotCascade) {
  YamlReader reader = YamlReader::from_text("present:\n  a: 1\n", "t.yaml");
  {
    YamlMapReader root = reader.root();
    YamlMapReader present = root.map("present");
    (void)present.read_float("a", Range::any());
    (void)present.read_float("b", Range::any());
    YamlMapReader absent = root.map("absent");
    (void)absent.read_float("x", Range::any());  // not reported: the mapping already is
    (void)absent.read_float("y", Range::any());
  }
  EXPECT_THAT(messages(reader),
              ElementsAre("t.yaml:2:3: present.b: missing key: required, not in present",
                          "t.yaml:1:1: absent: missing key: required, not in the file"));
}

TEST(YamlReader, ScalarWhereAMappingIs) {
  YamlReader reader = YamlReader::from_text("block: 5\n", "t.yaml");
  {
    YamlMapReader root = reader.root();
    YamlMapReader block = root.map("block");
    (void)block.read_float("x", Range::any());
  }
  EXPECT_THAT(messages(reader),
              ElementsAre("t.yaml:1:8: block: wrong type: expected a mapping, found \"5\""));
}

TEST(YamlReader, DuplicateKey) {
  YamlReader reader = YamlReader::from_text("a: 1\nb: 2\na: 3\n", "t.yaml");
  {
    YamlMapReader root = reader.root();
    (void)root.read_int<int>("a", Range::any());
    (void)root.read_int<int>("b", Range::any());
  }
  EXPECT_THAT(messages(reader),
              ElementsAre("t.yaml:3:1: a: duplicate key: already given at line 1"));
}

TEST(YamlReader, Sequences) {
  YamlReader reader = YamlReader::from_text(
      "speeds: [0.1, -0.2, 0.3]\n"
      "pair: [1.0, 2.0, 3.0]\n"
      "items:\n"
      "  - {name: a, mass_g: 150}\n"
      "  - {name: b, mass_g: 170, extra: 1}\n",
      "t.yaml");
  std::vector<std::string> names;
  {
    YamlMapReader root = reader.root();
    // -0.2 breaks the positive range; its element path and column are reported.
    EXPECT_THAT(root.read_floats("speeds", Range::positive()), ElementsAre(0.1F, 0.0F, 0.3F));
    EXPECT_THAT(root.read_doubles("pair", Range::any(), 2), IsEmpty());  // 3 elements, 2 wanted
    root.for_each_map("items", [&](YamlMapReader& item, std::size_t /*index*/) {
      names.push_back(item.read_string("name"));
      (void)item.read_int<int>("mass_g", Range::positive());
    });
  }
  EXPECT_THAT(names, ElementsAre("a", "b"));
  EXPECT_THAT(messages(reader),
              ElementsAre("t.yaml:1:15: speeds[1]: out of range: got -0.2, must be > 0",
                          "t.yaml:2:7: pair: invalid value: has 3 elements, expected 2",
                          "t.yaml:5:28: items[1].extra: unknown key: not a setting of items[1]"));
}

TEST(YamlReader, SyntaxErrorHasPosition) {
  YamlReader reader = YamlReader::from_text("a:\n  b: 1\n   c: 2\n", "t.yaml");
  (void)reader.root().read_float("a", Range::any());  // reads nothing: the document is broken
  ASSERT_EQ(reader.problems().size(), 1U);
  const ConfigProblem& problem = reader.problems().front();
  EXPECT_EQ(problem.kind, ProblemKind::kSyntax);
  EXPECT_EQ(problem.line, 3);  // the over-indented "c"
  EXPECT_THAT(problem.to_string(), HasSubstr("t.yaml:3:"));
  EXPECT_THAT(problem.to_string(), HasSubstr("invalid YAML syntax"));
}

// Found by fuzz/fuzz_line_config (corpus file regression_stray_comma): yaml-cpp 0.7's LoadAll
// never returns on a stray ',' and grows without bound; the reader reports a syntax error.
TEST(YamlReader, StrayCommaIsASyntaxErrorNotAHang) {
  for (const char* text : {",\xb9", ",", "# comment\n, a\n", "a: 1\n---\n,b\n"}) {
    SCOPED_TRACE(text);
    YamlReader reader = YamlReader::from_text(text, "t.yaml");
    ASSERT_EQ(reader.problems().size(), 1U);
    EXPECT_EQ(reader.problems().front().kind, ProblemKind::kSyntax);
    EXPECT_THAT(reader.problems().front().to_string(), HasSubstr("no YAML value can start here"));
  }
  // A comma inside a flow collection stays valid.
  EXPECT_THAT(messages(YamlReader::from_text("a: [1, 2]\n", "t.yaml")), IsEmpty());
}

TEST(YamlReader, DocumentShapes) {
  EXPECT_THAT(messages(YamlReader::from_text("", "t.yaml")),
              ElementsAre("t.yaml: empty file: no YAML document in the file"));
  {
    YamlReader reader = YamlReader::from_text("- 1\n- 2\n", "t.yaml");
    (void)reader.root();
    EXPECT_THAT(messages(reader), ElementsAre("t.yaml:1:1: wrong type: expected a mapping of "
                                              "settings at the top level, found a sequence"));
  }
  EXPECT_THAT(messages(YamlReader::from_text("a: 1\n---\na: 2\n", "t.yaml")),
              ElementsAre(HasSubstr("2 YAML documents (separated by ---), expected one")));
}

TEST(YamlReader, MissingFile) {
  const YamlReader reader = YamlReader::from_file("/nonexistent/dir/plant.yaml");
  EXPECT_THAT(messages(reader),
              ElementsAre("/nonexistent/dir/plant.yaml: cannot read file: no such file"));
}

TEST(YamlReader, RequireReportsAtTheFirstKeyUnlessAValueIsAlreadyBroken) {
  YamlReader reader = YamlReader::from_text("a_mm: 5\nb_mm: 3\nc_mm: -1\n", "t.yaml");
  float a_mm = 0.0F;
  float b_mm = 0.0F;
  float c_mm = 0.0F;
  {
    YamlMapReader root = reader.root();
    a_mm = root.read_float("a_mm", Range::any());
    b_mm = root.read_float("b_mm", Range::any());
    c_mm = root.read_float("c_mm", Range::positive());  // -1: reported here already
  }
  EXPECT_FALSE(reader.require(a_mm < b_mm, {"a_mm", "b_mm"}, "a_mm must be upstream of b_mm"));
  // c_mm holds a placeholder: no second, misleading message about it.
  EXPECT_FALSE(reader.require(c_mm > a_mm, {"c_mm", "a_mm"}, "c_mm must be downstream of a_mm"));
  EXPECT_THAT(messages(reader),
              ElementsAre("t.yaml:3:7: c_mm: out of range: got -1, must be > 0",
                          "t.yaml:1:1: a_mm: inconsistent values: a_mm must be upstream of b_mm"));
}

TEST(YamlReader, ConfigErrorListsOneProblemPerLine) {
  YamlReader reader = YamlReader::from_text("a: x\nb: y\n", "t.yaml");
  {
    YamlMapReader root = reader.root();
    (void)root.read_float("a", Range::any());
    (void)root.read_float("b", Range::any());
  }
  try {
    reader.throw_if_problems();
    FAIL() << "no ConfigError";
  } catch (const ConfigError& error) {
    EXPECT_EQ(error.problems().size(), 2U);  // a and b
    EXPECT_STREQ(error.what(),
                 "2 configuration problems:\n"
                 "t.yaml:1:4: a: wrong type: expected a number, found \"x\"\n"
                 "t.yaml:2:4: b: wrong type: expected a number, found \"y\"");
  }
}

TEST(YamlReader, FinishReportsOnceAndMovedFromReadersStaySilent) {
  YamlReader reader = YamlReader::from_text("typo: 1\n", "t.yaml");
  {
    YamlMapReader root = reader.root();
    YamlMapReader moved = std::move(root);
    moved.finish();
    moved.finish();                         // second call: nothing more
  }                                         // destructors: nothing more either
  EXPECT_EQ(reader.problems().size(), 1U);  // the one unknown key
}

}  // namespace
}  // namespace fl
