#include "common/status.h"

#include <gtest/gtest.h>

#include "common/log.h"

namespace yamor {
namespace {

TEST(StatusTest, CodesMatchGrpcNumbering) {
  EXPECT_EQ(static_cast<int>(StatusCode::kInvalidArgument), 3);
  EXPECT_EQ(static_cast<int>(StatusCode::kNotFound), 5);
  EXPECT_EQ(static_cast<int>(StatusCode::kFailedPrecondition), 9);
  EXPECT_EQ(static_cast<int>(StatusCode::kOutOfRange), 11);
  EXPECT_EQ(static_cast<int>(StatusCode::kUnavailable), 14);
}

TEST(StatusTest, NamesAreCanonical) {
  EXPECT_EQ(StatusCodeName(StatusCode::kInvalidArgument), "INVALID_ARGUMENT");
  EXPECT_EQ(StatusCodeName(StatusCode::kResourceExhausted), "RESOURCE_EXHAUSTED");
}

TEST(StatusTest, ErrorCarriesCodeAndMessage) {
  try {
    throw Error(StatusCode::kNotFound, "module 7 not found");
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kNotFound);
    EXPECT_STREQ(e.what(), "module 7 not found");
  }
}

TEST(LogTest, UnknownLevelIsRejected) {
  EXPECT_THROW(SetLogLevel("loud"), Error);
  EXPECT_NO_THROW(SetLogLevel("off"));
  EXPECT_NO_THROW(SetLogLevel("info"));
}

TEST(CheckDeathTest, FailedInvariantAborts) {
  EXPECT_DEATH(YAMOR_CHECK(1 + 1 == 3, "arithmetic broke"), "arithmetic broke");
}

}  // namespace
}  // namespace yamor
