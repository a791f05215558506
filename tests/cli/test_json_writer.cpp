// JsonObject (tools/cli/json_writer.hpp): the run summaries' layout and numbers.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "cli/json_writer.hpp"

namespace pointfair::cli {
namespace {

// The number after "\"v\": " in a one-member summary, read back.
double read_back(const std::string& json) {
  const std::string key = "{\"v\": ";
  EXPECT_EQ(json.rfind(key, 0), 0u) << json;
  return std::strtod(json.c_str() + key.size(), nullptr);
}

TEST(JsonWriter, OneLineWithTheSeparatorsTheSummariesAlwaysHad) {
  std::vector<JsonObject> runs;
  runs.push_back(JsonObject().add("i", 0));
  runs.push_back(JsonObject().add("i", 1));
  const JsonObject j = JsonObject()
                           .add("command", "smooth")
                           .add("points", std::size_t{2000})
                           .add("ok", true)
                           .add("params", JsonObject().add("k", 16).add("k_auto", false))
                           .add("runs", runs);
  EXPECT_EQ(j.str(), R"({"command": "smooth", "points": 2000, "ok": true, "params": {"k": 16, "k_auto": false}, )"
                     R"("runs": [{"i": 0}, {"i": 1}]})");
  EXPECT_EQ(JsonObject().str(), "{}");
  EXPECT_EQ(JsonObject().add("none", std::vector<JsonObject>{}).str(), R"({"none": []})");
}

TEST(JsonWriter, StringsAreEscaped) {
  EXPECT_EQ(JsonObject().add("s", "a\"b\\c\nd\te\x01").str(), R"({"s": "a\"b\\c\nd\te\u0001"})");
  // Bytes that are not UTF-8 (a file name, say) become U+FFFD: the summary stays JSON.
  EXPECT_EQ(JsonObject().add("s", "a\xff").str(), "{\"s\": \"a\xef\xbf\xbd\"}");
  EXPECT_EQ(JsonObject().add("s", "caf\xc3\xa9").str(), "{\"s\": \"caf\xc3\xa9\"}");
}

TEST(JsonWriter, WholeNumbersPrintWithoutAFractionAndNonFiniteAsNull) {
  EXPECT_EQ(JsonObject().add("v", 1.0).str(), R"({"v": 1})");
  EXPECT_EQ(JsonObject().add("v", 0.0).str(), R"({"v": 0})");
  EXPECT_EQ(JsonObject().add("v", -150.0).str(), R"({"v": -150})");
  EXPECT_EQ(JsonObject().add("v", 0.5).str(), R"({"v": 0.5})");
  EXPECT_EQ(JsonObject().add("v", 0.1).str(), R"({"v": 0.1})");
  EXPECT_EQ(JsonObject().add("v", std::numeric_limits<double>::quiet_NaN()).str(), R"({"v": null})");
  EXPECT_EQ(JsonObject().add("v", std::numeric_limits<double>::infinity()).str(), R"({"v": null})");
  EXPECT_EQ(JsonObject().add("v", -std::numeric_limits<double>::infinity()).str(), R"({"v": null})");
  EXPECT_TRUE(std::signbit(read_back(JsonObject().add("v", -0.0).str())));
}

TEST(JsonWriter, EveryDoubleReadsBackExactly) {
  std::mt19937_64 random(7);
  std::uniform_real_distribution<double> mantissa(-1.0, 1.0);
  std::uniform_int_distribution<int> exponent(-300, 300);
  for (int i = 0; i < 20000; ++i) {
    double v = mantissa(random) * std::pow(10.0, exponent(random));
    if (i % 5 == 0) v = std::round(v * 1e3) / 1e3;  // whole numbers and short decimals too
    const double back = read_back(JsonObject().add("v", v).str());
    EXPECT_EQ(std::memcmp(&back, &v, sizeof v), 0) << v;
  }
  for (const double v : {std::numeric_limits<double>::max(), std::numeric_limits<double>::min(),
                         std::numeric_limits<double>::denorm_min(), 9007199254740993.0, 1e300}) {
    const double back = read_back(JsonObject().add("v", v).str());
    EXPECT_EQ(back, v);
  }
}

TEST(JsonWriter, CopiesAndMovesKeepTheMembers) {
  JsonObject a;
  a.add("x", 1);
  JsonObject b = a;
  b.add("y", 2);
  EXPECT_EQ(a.str(), R"({"x": 1})");
  EXPECT_EQ(b.str(), R"({"x": 1, "y": 2})");
  JsonObject c = std::move(b);
  EXPECT_EQ(c.str(), R"({"x": 1, "y": 2})");
  a = c;
  EXPECT_EQ(a.str(), c.str());
}

}  // namespace
}  // namespace pointfair::cli
