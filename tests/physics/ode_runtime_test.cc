#include "physics/ode_runtime.h"

#include <thread>

#include <ode/ode.h>

#include <gtest/gtest.h>

namespace yamor::physics {
namespace {

TEST(OdeRuntimeTest, OdeErrorsThrowInsteadOfExiting) {
  EnsureOdeForThisThread();
  // ODE calls exit() after dError's handler and abort() after dDebug's: ours
  // throw, so the process survives.
  EXPECT_THROW(dError(1, "test error %d", 42), OdeFailure);
  EXPECT_THROW(dDebug(2, "test debug"), OdeFailure);
  try {
    dError(1, "value %d", 42);
  } catch (const OdeFailure& failure) {
    EXPECT_EQ(failure.code(), StatusCode::kInternal);
    EXPECT_NE(std::string(failure.what()).find("value 42"), std::string::npos);
  }
  dMessage(3, "informative messages are only logged");
}

TEST(OdeRuntimeTest, EveryThreadCanUseOde) {
  std::thread worker([] {
    EnsureOdeForThisThread();
    dWorldID world = dWorldCreate();
    dSpaceID space = dHashSpaceCreate(nullptr);
    dCreateBox(space, 1, 1, 1);
    dSpaceDestroy(space);
    dWorldDestroy(world);
  });
  worker.join();
  SUCCEED();
}

}  // namespace
}  // namespace yamor::physics
