// LP_NUM_THREADS defaults to 0 (one rasteriser thread: the caller's) unless
// the user has set it. ctest runs every test in its own process, so changing
// the environment here cannot leak into a renderer made by another test.
#include "physics/render/raster_threads.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <optional>
#include <string>

namespace yamor::render {
namespace {

// Restores LP_NUM_THREADS as it was when the test started.
class RasterThreadsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (const char* v = std::getenv(kRasterThreadsVariable)) saved_ = v;
  }
  void TearDown() override {
    if (saved_) {
      ::setenv(kRasterThreadsVariable, saved_->c_str(), 1);
    } else {
      ::unsetenv(kRasterThreadsVariable);
    }
  }
  std::optional<std::string> saved_;
};

TEST(RasterThreadsToSetTest, UnsetBecomesZeroAndAnyUserValueStands) {
  EXPECT_EQ(RasterThreadsToSet(nullptr), std::optional<std::string>("0"));
  EXPECT_EQ(RasterThreadsToSet("4"), std::nullopt);
  EXPECT_EQ(RasterThreadsToSet("0"), std::nullopt);
  EXPECT_EQ(RasterThreadsToSet(""), std::nullopt);  // set, even if empty: the user's
}

TEST_F(RasterThreadsTest, SetsZeroWhenUnset) {
  ASSERT_EQ(::unsetenv(kRasterThreadsVariable), 0);
  EXPECT_TRUE(DefaultToOneRasterThread());
  ASSERT_NE(std::getenv(kRasterThreadsVariable), nullptr);
  EXPECT_STREQ(std::getenv(kRasterThreadsVariable), "0");
  // A second call sees the value it set and leaves it.
  EXPECT_FALSE(DefaultToOneRasterThread());
  EXPECT_STREQ(std::getenv(kRasterThreadsVariable), "0");
}

TEST_F(RasterThreadsTest, KeepsTheUsersValue) {
  for (const char* user : {"3", "0", ""}) {
    ASSERT_EQ(::setenv(kRasterThreadsVariable, user, 1), 0);
    EXPECT_FALSE(DefaultToOneRasterThread()) << "LP_NUM_THREADS=\"" << user << "\"";
    EXPECT_STREQ(std::getenv(kRasterThreadsVariable), user);
  }
}

}  // namespace
}  // namespace yamor::render
