// CSV writer and reader: round trip, RFC 4180 quoting, and clear errors for malformed input.
#include "fl/report/csv.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

namespace fl::report {
namespace {

TEST(Csv, RoundTripsNumbersAndQuotedText) {
  CsvTable table({"time_s", "force_n", "note"});
  table.add_row({0.1, -2.5e-7, std::string("plain")});
  table.add_row({1e300, 3.0, std::string("comma, \"quote\"\nand newline")});
  table.add_row({CsvCell{}, 0.0, std::string()});  // missing value: empty cell
  const auto rows = parse_csv(table.to_string());
  ASSERT_EQ(rows.size(), 4U);
  EXPECT_EQ(rows[0], (std::vector<std::string>{"time_s", "force_n", "note"}));
  EXPECT_EQ(std::stod(rows[1][0]), 0.1);  // shortest round-trip text reads back exactly
  EXPECT_EQ(std::stod(rows[1][1]), -2.5e-7);
  EXPECT_EQ(rows[2][2], "comma, \"quote\"\nand newline");
  EXPECT_EQ(rows[3][0], "");
  EXPECT_EQ(rows[3][2], "");
}

TEST(Csv, QuoteOfOneFieldIsTheTablesQuote) {
  EXPECT_EQ(csv_quote("plain"), "plain");
  EXPECT_EQ(csv_quote("lab, week 3"), "\"lab, week 3\"");
  EXPECT_EQ(csv_quote("say \"hi\""), "\"say \"\"hi\"\"\"");
  EXPECT_EQ(csv_quote("two\nlines"), "\"two\nlines\"");
  EXPECT_EQ(parse_csv(csv_quote("a,\"b\"") + ",x\n").at(0),
            (std::vector<std::string>{"a,\"b\"", "x"}));
}

TEST(Csv, QuotesOnlyWhereNeededWithCrlfLineEnds) {
  CsvTable table({"a", "b"});
  table.add_row({std::string("x\"y"), 1.0});
  EXPECT_EQ(table.to_string(), "a,b\r\n\"x\"\"y\",1\r\n");
}

TEST(Csv, AddColumnsWritesOneRowPerIndex) {
  CsvTable table({"x_m", "y_m"});
  table.add_columns({{1, 2, 3}, {4, 5, 6}});
  EXPECT_EQ(table.row_count(), 3U);
  EXPECT_EQ(parse_csv(table.to_string())[3][1], "6");
}

TEST(Csv, WritesFileThatParsesBack) {
  const auto dir = std::filesystem::temp_directory_path() / "fl_report_csv_test";
  CsvTable table({"speed_mps"});
  table.add_row({2.0});
  table.write(dir / "sub" / "t.csv");
  std::ifstream in(dir / "sub" / "t.csv", std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_EQ(parse_csv(text.str()).size(), 2U);
  std::filesystem::remove_all(dir);
}

TEST(Csv, RejectsMalformedInputWithClearMessages) {
  EXPECT_THROW(CsvTable({}), ReportError);
  EXPECT_THROW(CsvTable({"a", ""}), ReportError);
  EXPECT_THROW(CsvTable({"a", "a"}), ReportError);
  CsvTable table({"a_m", "b_m"});
  try {
    table.add_row({1.0});
    FAIL() << "a short row must throw";
  } catch (const ReportError& e) {
    EXPECT_NE(std::string(e.what()).find("row 0 has 1 cells"), std::string::npos) << e.what();
  }
  try {
    table.add_row({1.0, std::numeric_limits<double>::quiet_NaN()});
    FAIL() << "NaN must throw";
  } catch (const ReportError& e) {
    EXPECT_NE(std::string(e.what()).find("'b_m'"), std::string::npos) << e.what();
  }
  EXPECT_THROW(table.add_row({1.0, std::numeric_limits<double>::infinity()}), ReportError);
  EXPECT_THROW(table.add_columns({{1.0, 2.0}, {1.0}}), ReportError);
  EXPECT_EQ(table.row_count(), 0U);
}

TEST(Csv, ParserRejectsBrokenQuoting) {
  EXPECT_THROW(parse_csv("a,\"open\n"), ReportError);
  EXPECT_THROW(parse_csv("\"a\"x,b\n"), ReportError);
  EXPECT_EQ(parse_csv("a,b\nc,d").size(), 2U);  // LF and no final line end are accepted
}

}  // namespace
}  // namespace fl::report
