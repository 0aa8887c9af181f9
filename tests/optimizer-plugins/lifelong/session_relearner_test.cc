// The relearner's plugin fields (session_relearner.h): the mode's default
// budget, and in model mode a batch line search for a plugin that has one,
// so the host pool's workers evaluate a line's points at once. No daemon is
// called: the port only opens a channel to an unused loopback port.
#include "optimizer-plugins/lifelong/session_relearner.h"

#include <gtest/gtest.h>

#include <map>
#include <string>

#include "common/status.h"

namespace yamor::lifelong {
namespace {

std::map<std::string, std::string> FieldsOf(const std::string& plugin, const std::string& mode,
                                            std::map<std::string, std::string> set = {}) {
  DaemonPort port(optimizer::HostAddress{.host = "127.0.0.1", .port = 1}, {});
  RelearnerOptions options;
  options.mode = mode;
  options.plugin = plugin;
  options.plugin_dirs = {YAMOR_PLUGIN_DIR};
  options.set = std::move(set);
  return SessionRelearner(port, options).Fields();
}

TEST(SessionRelearnerTest, ModelModeUsesPowellsBatchLineSearch) {
  const auto fields = FieldsOf("powell", "model");
  EXPECT_EQ(fields.at("line_search"), "interval");
  EXPECT_EQ(fields.at("max_evaluations"), "250");
}

TEST(SessionRelearnerTest, OnlineKeepsThePluginsOwnLineSearch) {
  const auto fields = FieldsOf("powell", "online");
  EXPECT_EQ(fields.count("line_search"), 0u);
  EXPECT_EQ(fields.at("max_evaluations"), "100");
}

TEST(SessionRelearnerTest, AGivenLineSearchWins) {
  const auto fields = FieldsOf("powell", "model", {{"line_search", "brent"}, {"max_evaluations", "50"}});
  EXPECT_EQ(fields.at("line_search"), "brent");
  EXPECT_EQ(fields.at("max_evaluations"), "50");
}

TEST(SessionRelearnerTest, APluginWithoutALineSearchGetsNone) {
  const auto fields = FieldsOf("random", "model");
  EXPECT_EQ(fields.count("line_search"), 0u);
}

// Each mode's own budget applies unless --set gives max_evaluations, which
// then is the budget of both.
TEST(SessionRelearnerTest, EachModeHasItsOwnBudgetUnlessSetGivesOne) {
  DaemonPort port(optimizer::HostAddress{.host = "127.0.0.1", .port = 1}, {});
  RelearnerOptions options;
  options.plugin = "powell";
  options.plugin_dirs = {YAMOR_PLUGIN_DIR};
  options.online_budget = 45;
  options.model_budget = 250;
  options.mode = "online";
  EXPECT_EQ(SessionRelearner(port, options).Fields().at("max_evaluations"), "45");
  options.mode = "model";
  EXPECT_EQ(SessionRelearner(port, options).Fields().at("max_evaluations"), "250");
  options.set = {{"max_evaluations", "60"}};
  EXPECT_EQ(SessionRelearner(port, options).Fields().at("max_evaluations"), "60");
  options.mode = "online";
  EXPECT_EQ(SessionRelearner(port, options).Fields().at("max_evaluations"), "60");
}

TEST(SessionRelearnerTest, ABudgetBelowOneIsRefusedNamingIt) {
  RelearnerOptions options;
  options.model_budget = 0;
  try {
    ValidateRelearnerOptions(options);
    FAIL() << "a model budget of 0 was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kInvalidArgument);
    EXPECT_NE(std::string(e.what()).find("model budget 0"), std::string::npos) << e.what();
  }
  options.model_budget = 300;
  options.online_budget = -3;
  EXPECT_THROW(ValidateRelearnerOptions(options), Error);
}

}  // namespace
}  // namespace yamor::lifelong
