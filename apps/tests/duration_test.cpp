#include "../linectl/duration.hpp"

#include <gtest/gtest.h>

namespace fl::apps {
namespace {

TEST(ParseDuration, UnitsAndCombinations) {
  EXPECT_EQ(parse_duration_s("90"), 90.0);  // a bare number is seconds
  EXPECT_EQ(parse_duration_s("90s"), 90.0);
  EXPECT_EQ(parse_duration_s("10m"), 600.0);
  EXPECT_EQ(parse_duration_s("1h"), 3600.0);
  EXPECT_EQ(parse_duration_s("1h30m"), 5400.0);
  EXPECT_EQ(parse_duration_s("1.5m"), 90.0);
}

TEST(ParseDuration, MalformedTextIsRefused) {
  for (const char* text :
       {"", "m", "10x", "-5s", "0", "0s", "1h30", "s10", "10 m", "1e400s", "inf", "nan", "infs"}) {
    EXPECT_FALSE(parse_duration_s(text).has_value()) << '"' << text << '"';
  }
}

}  // namespace
}  // namespace fl::apps
