// Parameter names (DESIGN.md: amplitude.3, phase.2.5, ...).
#include "cpg/parameters.h"

#include <gtest/gtest.h>

#include <string>

#include "common/status.h"

namespace yamor::cpg {
namespace {

TEST(ParseParameterNameTest, ModuleAndCouplingFields) {
  const ParameterName amplitude = ParseParameterName("amplitude.3");
  EXPECT_FALSE(amplitude.coupling);
  EXPECT_EQ(amplitude.module_field, ModuleField::kAmplitude);
  EXPECT_EQ(amplitude.id, 3);
  EXPECT_EQ(ParseParameterName("offset.0").module_field, ModuleField::kOffset);
  EXPECT_EQ(ParseParameterName("speed.254").module_field, ModuleField::kSpeed);
  EXPECT_EQ(ParseParameterName("minangle.7").module_field, ModuleField::kMinAngle);
  EXPECT_EQ(ParseParameterName("maxangle.7").module_field, ModuleField::kMaxAngle);
  const ParameterName phase = ParseParameterName("phase.2.5");
  EXPECT_TRUE(phase.coupling);
  EXPECT_EQ(phase.coupling_field, CouplingField::kPhase);
  EXPECT_EQ(phase.from, 2);
  EXPECT_EQ(phase.to, 5);
  EXPECT_EQ(ParseParameterName("weight.5.2").coupling_field, CouplingField::kWeight);
}

TEST(ParseParameterNameTest, MalformedNamesAreInvalidArguments) {
  for (const char* name : {"", "amplitude", "amplitude.", "amplitude.x", "amplitude.255",
                           "amplitude.-1", "amplitude.3.4", "phase.2", "phase.2.", "phase.2.x",
                           "weight.300.1", "torque.3", "Amplitude.3"}) {
    try {
      ParseParameterName(name);
      ADD_FAILURE() << "'" << name << "' parsed";
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), StatusCode::kInvalidArgument) << name;
    }
  }
}

TEST(ApplyParametersTest, ErrorsNameTheParameter) {
  RobotConfig config;
  config.master_id = 0;
  config.modules = {ModuleParams{.id = 0}, ModuleParams{.id = 1}};
  try {
    ApplyParameters(config, {{"amplitude.9", 0.5}});
    ADD_FAILURE() << "module 9 accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kNotFound);
    EXPECT_NE(std::string(e.what()).find("amplitude.9"), std::string::npos) << e.what();
  }
  ApplyParameters(config, {{"amplitude.1", 0.5}, {"speed.0", 2.0}});
  EXPECT_EQ(config.FindModule(1)->amplitude, 0.5);
  EXPECT_EQ(config.FindModule(0)->speed, 2.0);
}

}  // namespace
}  // namespace yamor::cpg
