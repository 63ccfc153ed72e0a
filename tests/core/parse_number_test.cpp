// Strict number parsing (issue 12): the whole field, range-checked.
#include "orpe/core/parse_number.h"

#include <gtest/gtest.h>

#include "orpe/core/error.h"

namespace orpe {
namespace {

TEST(ParseNumber, IntegersAreReadWholeAndRangeChecked) {
  long long v = 0;
  std::string why;
  EXPECT_TRUE(parse_integer("14", 0, 100, &v, &why));
  EXPECT_EQ(v, 14);
  EXPECT_TRUE(parse_integer("-7", -10, 10, &v, &why));
  EXPECT_EQ(v, -7);
  // std::stoi reads these by prefix as 1, 14 and 1.
  for (const char* bad : {"1.5", "14abc", "1e+20", " 3", "3 ", "+3", "", "0x10", "--1"}) {
    EXPECT_FALSE(parse_integer(bad, INT_MIN, INT_MAX, &v, &why)) << bad;
    EXPECT_FALSE(why.empty());
  }
  EXPECT_FALSE(parse_integer("99999999999", 0, INT_MAX, &v, &why));
  EXPECT_NE(why.find("out of range"), std::string::npos) << why;
  EXPECT_FALSE(parse_integer("999999999999999999999999", 0, INT_MAX, &v, &why));
  EXPECT_NE(why.find("out of range"), std::string::npos) << why;
  EXPECT_FALSE(parse_integer("-1", 0, 10, &v, &why));
}

TEST(ParseNumber, RealsAreReadWholeAndNonFiniteOnRequest) {
  double x = 0;
  std::string why;
  EXPECT_TRUE(parse_real("1.5e3", true, &x, &why));
  EXPECT_DOUBLE_EQ(x, 1500);
  EXPECT_TRUE(parse_real("+2", true, &x, &why));
  EXPECT_DOUBLE_EQ(x, 2);
  EXPECT_TRUE(parse_real("-inf", false, &x, &why));
  for (const char* bad : {"nan", "inf", "1e400", "1.5x", "", "+-1", "1,5"})
    EXPECT_FALSE(parse_real(bad, true, &x, &why)) << bad;
}

TEST(ParseNumber, FieldErrorsNameFileLineAndField) {
  try {
    parse_int_field("1.5", "poses.csv", "line 3, field im_id", 0);
    ADD_FAILURE() << "no error";
  } catch (const IoError& e) {
    EXPECT_EQ(std::string(e.what()), "poses.csv: line 3, field im_id: '1.5' is not an integer");
  }
  EXPECT_THROW(parse_finite_field("nan", "poses.csv", "line 3, field score"), IoError);
}

}  // namespace
}  // namespace orpe
