// Units of measurement files and the CSV line splitter.
#include "fl/workbench/units.hpp"

#include <gtest/gtest.h>

#include <numbers>

#include "csv_reader.hpp"

namespace fl::workbench {
namespace {

TEST(Units, QuantitiesConvertToSi) {
  const QuantityParse length = parse_quantity("12.5 mm");
  ASSERT_TRUE(length.value) << length.error;
  EXPECT_EQ(length.value->unit.quantity, Quantity::kLength);
  EXPECT_DOUBLE_EQ(length.value->value_si, 0.0125);
  EXPECT_DOUBLE_EQ(parse_quantity("3 deg").value->value_si, std::numbers::pi / 60.0);
  EXPECT_DOUBLE_EQ(parse_quantity("6 kg/min").value->value_si, 0.1);
  EXPECT_DOUBLE_EQ(parse_quantity("5 deg/s").value->value_si, std::numbers::pi / 36.0);
  EXPECT_DOUBLE_EQ(parse_quantity(" 2 ").value->value_si, 2.0);
  EXPECT_EQ(parse_quantity("2").value->unit.quantity, Quantity::kDimensionless);
}

TEST(Units, MalformedQuantitiesSayWhy) {
  EXPECT_NE(parse_quantity("2mm").error.find("space between"), std::string::npos);
  EXPECT_NE(parse_quantity("mm").error.find("does not start with a number"), std::string::npos);
  EXPECT_NE(parse_quantity("1 furlong").error.find("unknown unit 'furlong'"), std::string::npos);
  EXPECT_NE(parse_quantity("nan N").error.find("not a finite number"), std::string::npos);
  EXPECT_NE(parse_quantity("").error.find("does not start with a number"), std::string::npos);
  // Case matters: MN would be a meganewton, which no fillet test reaches.
  EXPECT_FALSE(find_unit("MN").has_value());
}

TEST(Units, EveryQuantityHasItsSiUnit) {
  for (const Quantity q :
       {Quantity::kTime, Quantity::kLength, Quantity::kAngle, Quantity::kForce, Quantity::kMass,
        Quantity::kSpeed, Quantity::kMassFlow, Quantity::kEnergy, Quantity::kRate,
        Quantity::kAngularSpeed, Quantity::kDimensionless}) {
    const auto unit = find_unit(si_unit(q));
    ASSERT_TRUE(unit.has_value()) << to_string(q);
    EXPECT_EQ(unit->to_si, 1.0);
    EXPECT_EQ(unit->quantity, q);
  }
}

TEST(CsvLine, QuotedFieldsAndTheirErrors) {
  std::vector<std::string> fields;
  std::string error;
  ASSERT_TRUE(detail::split_csv_line(R"(a,"b,c","say ""hi""",)", fields, error));
  EXPECT_EQ(fields, (std::vector<std::string>{"a", "b,c", R"(say "hi")", ""}));
  EXPECT_FALSE(detail::split_csv_line(R"("open,1)", fields, error));
  EXPECT_NE(error.find("not closed"), std::string::npos);
  EXPECT_FALSE(detail::split_csv_line(R"("a"b,1)", fields, error));
  EXPECT_NE(error.find("after a closing quote"), std::string::npos);
  EXPECT_FALSE(detail::split_csv_line(R"(a"b,1)", fields, error));
  EXPECT_NE(error.find("inside an unquoted field"), std::string::npos);
}

}  // namespace
}  // namespace fl::workbench
