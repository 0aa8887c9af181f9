#include "optimizer-plugins/framework/plugin_loader.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>

#include "common/status.h"
#include "yamor/optimizer_plugin.hpp"

namespace yamor::optimizer {
namespace {

std::string TestPlugin(const std::string& name) {
  return std::string(TEST_PLUGIN_DIR) + "/" + name + ".so";
}

// The message of the error Load throws for `name`.
std::string LoadError(const std::string& name) {
  try {
    LoadedPlugin::Load(TestPlugin(name));
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kFailedPrecondition);
    return e.what();
  }
  ADD_FAILURE() << name << " loaded";
  return "";
}

TEST(PluginLoader, LoadsAPluginAndItsFields) {
  LoadedPlugin p = LoadedPlugin::Load(TestPlugin("compass"));
  EXPECT_EQ(p.name(), "compass");
  EXPECT_EQ(p.version(), "1.0.0");
  EXPECT_EQ(p.author(), "yamor tests");
  ASSERT_EQ(p.fields().size(), 5u);
  EXPECT_EQ(p.fields()[0].name, "max_evaluations");
  EXPECT_TRUE(p.fields()[0].framework);
  EXPECT_EQ(p.fields()[1].name, "step");
  EXPECT_EQ(p.fields()[4].choices, (std::vector<std::string>{"a", "b", "c"}));
}

TEST(PluginLoader, RejectsAWrongAbiVersion) {
  const std::string e = LoadError("wrong_version");
  EXPECT_NE(e.find("ABI version 2"), std::string::npos) << e;
  EXPECT_NE(e.find("wrong_version.so"), std::string::npos) << e;
}

TEST(PluginLoader, RejectsAStructSmallerThanVersionOnes) {
  const std::string e = LoadError("wrong_size");
  EXPECT_NE(e.find(std::to_string(YAMOR_OPTIMIZER_PLUGIN_V1_SIZE - 8) + " bytes"), std::string::npos)
      << e;
  EXPECT_NE(e.find("smaller than ABI version 1's " + std::to_string(YAMOR_OPTIMIZER_PLUGIN_V1_SIZE)),
            std::string::npos)
      << e;
  EXPECT_NE(e.find("wrong_size.so"), std::string::npos) << e;
}

TEST(PluginLoader, AcceptsALargerStructFromANewerHeader) {
  const LoadedPlugin p = LoadedPlugin::Load(TestPlugin("larger"));
  EXPECT_GT(p.api().struct_size, YAMOR_OPTIMIZER_PLUGIN_V1_SIZE);
  EXPECT_EQ(p.name(), "larger");
  EXPECT_EQ(p.version(), "2");
  ASSERT_NE(p.api().run, nullptr);
  EXPECT_EQ(p.fields().size(), 1u) << "max_evaluations only";
}

// A plugin's side of the rule: the C++ wrapper refuses a context smaller
// than version 1's instead of reading past its end.
class NeverRuns : public yamor::plugin::Optimizer {
 public:
  void Run(yamor::plugin::Context&) override { ADD_FAILURE() << "ran with a short context"; }
};

TEST(PluginContext, ASmallerContextIsRefusedWithItsSize) {
  YamorOptimizerContext context{};
  context.abi_version = YAMOR_OPTIMIZER_ABI_VERSION;
  context.struct_size = static_cast<uint32_t>(offsetof(YamorOptimizerContext, random));
  char error[256] = "";
  EXPECT_EQ(yamor::plugin::RunOptimizer<NeverRuns>(&context, error, sizeof(error)), YAMOR_FAILED);
  EXPECT_NE(std::string(error).find("struct_size " + std::to_string(context.struct_size)),
            std::string::npos)
      << error;
  EXPECT_NE(std::string(error).find(std::to_string(YAMOR_OPTIMIZER_CONTEXT_V1_SIZE)),
            std::string::npos)
      << error;
}

TEST(PluginLoader, ReportsAMissingSymbolWithDlerror) {
  const std::string e = LoadError("no_symbol");
  EXPECT_NE(e.find("yamor_optimizer_plugin"), std::string::npos) << e;
  EXPECT_NE(e.find("undefined symbol"), std::string::npos) << e;  // dlerror()'s text
}

TEST(PluginLoader, ReportsAFileThatIsNotALibraryWithDlerror) {
  const std::string path = ::testing::TempDir() + "/not_a_plugin.so";
  { std::ofstream(path) << "hello"; }
  try {
    LoadedPlugin::Load(path);
    FAIL() << "loaded";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cannot be loaded"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("not_a_plugin.so"), std::string::npos) << e.what();
  }
}

TEST(PluginLoader, RejectsAFieldWithAnInvalidDefault) {
  const std::string e = LoadError("bad_field");
  EXPECT_NE(e.find("'steps'"), std::string::npos) << e;
  EXPECT_NE(e.find("invalid default"), std::string::npos) << e;
}

TEST(PluginLoader, ResolvesAndValidatesFieldValues) {
  LoadedPlugin p = LoadedPlugin::Load(TestPlugin("compass"));
  auto values = ResolveFieldValues(p, {{"step", "0.5"}, {"random_start", "yes"}});
  EXPECT_EQ(values.at("step"), "0.5");
  EXPECT_EQ(values.at("random_start"), "true");
  EXPECT_EQ(values.at("tolerance"), "0.001");
  EXPECT_EQ(values.at("max_evaluations"), "1000");

  auto expect_error = [&](const std::map<std::string, std::string>& set, const std::string& part) {
    try {
      ResolveFieldValues(p, set);
      ADD_FAILURE() << "accepted " << part;
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), StatusCode::kInvalidArgument);
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
    }
  };
  expect_error({{"stpe", "1"}}, "no field 'stpe' (fields: max_evaluations, step");
  expect_error({{"step", "2"}}, "'2' is not in [1e-06, 1]");
  expect_error({{"step", "nan"}}, "not a finite number");
  expect_error({{"max_evaluations", "1.5"}}, "not an integer");
  expect_error({{"max_evaluations", "0"}}, "not in [1, 1e+09]");
  expect_error({{"random_start", "maybe"}}, "not a boolean");
  expect_error({{"mode", "d"}}, "not one of a|b|c");
}

TEST(PluginLoader, FindsPluginsByNameOrPath) {
  const std::vector<std::string> dirs = {"/nonexistent", TEST_PLUGIN_DIR};
  EXPECT_EQ(FindPlugin("compass", dirs), TestPlugin("compass"));
  EXPECT_EQ(FindPlugin(TestPlugin("compass"), {}), TestPlugin("compass"));
  try {
    FindPlugin("nosuch", dirs);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kNotFound);
    EXPECT_NE(std::string(e.what()).find("/nonexistent, " TEST_PLUGIN_DIR), std::string::npos)
        << e.what();
  }
  const auto files = ListPluginFiles(dirs);
  EXPECT_NE(std::find(files.begin(), files.end(), TestPlugin("compass")), files.end());
}

}  // namespace
}  // namespace yamor::optimizer
