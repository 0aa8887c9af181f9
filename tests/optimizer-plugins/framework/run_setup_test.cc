// The batch file (--batch TOML) reader: instances, defaults, and every
// refusal naming the file and line.
#include "optimizer-plugins/framework/run_setup.h"

#include <gtest/gtest.h>

#include <string>

#include "common/status.h"
#include "tests/support/code_of.h"

namespace yamor::optimizer {
namespace {

using ::yamor::testing::CodeOf;

std::string Refusal(const std::string& text) {
  try {
    ParseBatchToml(text, "b.toml", 10);
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kInvalidArgument);
    return e.what();
  }
  return "accepted";
}

TEST(BatchFile, ReadsTheDocumentedExampleWithDefaults) {
  const auto instances = ParseBatchToml(R"([[instance]]
name = "classic"
seed = 1

[[instance]]
[instance.set]
line_search = "interval"
max_evaluations = 300
step = 0.25
verbose = true
)", "b.toml", 10);
  ASSERT_EQ(instances.size(), 2u);
  EXPECT_EQ(instances[0].name, "classic");
  EXPECT_EQ(instances[0].seed, 1u);
  EXPECT_EQ(instances[1].name, "instance-2");
  EXPECT_EQ(instances[1].seed, 11u) << "default: --seed + instance number";
  EXPECT_EQ(instances[1].set.at("line_search"), "interval");
  EXPECT_EQ(instances[1].set.at("max_evaluations"), "300");
  EXPECT_EQ(instances[1].set.at("step"), "0.25");
  EXPECT_EQ(instances[1].set.at("verbose"), "true");
}

TEST(BatchFile, RefusesBadInstancesNamingTheLine) {
  EXPECT_NE(Refusal("").find("no [[instance]]"), std::string::npos);
  EXPECT_NE(Refusal("x = 1\n").find("b.toml:1: unknown key 'x'"), std::string::npos);
  EXPECT_NE(Refusal("[[instance]]\nname = \"a\"\n[[instance]]\nname = \"a\"\n")
                .find("instance name 'a' is used twice"),
            std::string::npos);
  EXPECT_NE(Refusal("[[instance]]\nname = \"..\"\n").find("b.toml:2: name must be"),
            std::string::npos);
  EXPECT_NE(Refusal("[[instance]]\nname = \"a/b\"\n").find("name must be"), std::string::npos);
  EXPECT_NE(Refusal("[[instance]]\nseed = -1\n").find("seed must be an integer >= 0"),
            std::string::npos);
  EXPECT_NE(Refusal("[[instance]]\nseed = 1.5\n").find("seed must be"), std::string::npos);
  EXPECT_NE(Refusal("[[instance]]\n[instance.set]\nx = [1]\n").find("set.x must be"),
            std::string::npos);
  EXPECT_NE(Refusal("[[instance]]\nname = \"a\n").find("b.toml:2:"), std::string::npos);
}

// Found by batch_fuzzer's 10-minute run under UBSan (now a corpus seed,
// tests/fuzz/corpus/batch_fuzzer/regression-huge-float-seed.toml): a float
// seed beyond int64's range reached toml++'s float-to-integer conversion,
// which is undefined behaviour there. Only integers are converted now.
TEST(BatchFile, RefusesAFloatSeedOfAnySize) {
  for (const char* seed : {"9.3e19", "-9.3e19", "1e300", "2.0", "inf", "nan"}) {
    EXPECT_NE(Refusal(std::string("[[instance]]\nseed = ") + seed + "\n")
                  .find("b.toml:2: seed must be an integer >= 0"),
              std::string::npos)
        << seed;
  }
}

// Caught by batch_fuzzer's check on a hand-made input, now a corpus seed
// (tests/fuzz/corpus/batch_fuzzer/regression-empty-field-name.toml):
// `"" = 1` is valid TOML and was passed on as a field named "".
TEST(BatchFile, RefusesAnEmptyFieldName) {
  EXPECT_NE(Refusal("[[instance]]\n[instance.set]\n\"\" = 1\n")
                .find("b.toml:3: set has an empty field name"),
            std::string::npos);
}

TEST(BatchFile, AMissingFileIsNotFound) {
  EXPECT_EQ(CodeOf([] { LoadBatchFile("/nonexistent/batch.toml", 1); }), StatusCode::kNotFound);
}

}  // namespace
}  // namespace yamor::optimizer
