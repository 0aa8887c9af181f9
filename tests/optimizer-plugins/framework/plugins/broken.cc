// Deliberately broken plugins for the loader tests; BROKEN_KIND selects one.
#include <cstdint>
#include <stdexcept>

#include "yamor/optimizer_plugin.hpp"

namespace {

class Throws : public yamor::plugin::Optimizer {
 public:
  void Run(yamor::plugin::Context& context) override {
    context.Evaluate(context.Start());
    throw std::runtime_error("the test plugin gives up");
  }
};

class OutOfBounds : public yamor::plugin::Optimizer {
 public:
  void Run(yamor::plugin::Context& context) override {
    std::vector<double> x = context.Upper();
    x[0] += 1.0;
    context.Evaluate(x);
  }
};

[[maybe_unused]] const YamorField kNoFields[] = {{"unused", "", YAMOR_FIELD_INTEGER, 0, 10, "1", nullptr}};

[[maybe_unused]] int32_t RunNothing(const YamorOptimizerContext*, char*, size_t) { return YAMOR_OK; }

}  // namespace

#if BROKEN_KIND == 1  // wrong ABI version
extern "C" YAMOR_OPTIMIZER_EXPORT const YamorOptimizerPlugin* yamor_optimizer_plugin(void) {
  static const YamorOptimizerPlugin plugin = {YAMOR_OPTIMIZER_ABI_VERSION + 1, sizeof(YamorOptimizerPlugin),
                                              "future", "9", "t", "d", 0, nullptr, &RunNothing};
  return &plugin;
}
#elif BROKEN_KIND == 2  // a struct smaller than version 1's
extern "C" YAMOR_OPTIMIZER_EXPORT const YamorOptimizerPlugin* yamor_optimizer_plugin(void) {
  static const YamorOptimizerPlugin plugin = {YAMOR_OPTIMIZER_ABI_VERSION, sizeof(YamorOptimizerPlugin) - 8,
                                              "small", "1", "t", "d", 0, nullptr, &RunNothing};
  return &plugin;
}
#elif BROKEN_KIND == 3  // missing entry symbol
extern "C" YAMOR_OPTIMIZER_EXPORT int yamor_something_else(void) { return 0; }
#elif BROKEN_KIND == 4  // a field with an invalid default
const YamorField kBadFields[] = {{"steps", "", YAMOR_FIELD_INTEGER, 1, 10, "100", nullptr}};
YAMOR_OPTIMIZER_PLUGIN(Throws, "badfield", "1", "t", "d", kBadFields)
#elif BROKEN_KIND == 5  // throws from Run
YAMOR_OPTIMIZER_PLUGIN(Throws, "throws", "1", "t", "d", kNoFields)
#elif BROKEN_KIND == 6  // submits a point outside the bounds
YAMOR_OPTIMIZER_PLUGIN(OutOfBounds, "outofbounds", "1", "t", "d", kNoFields)
#elif BROKEN_KIND == 7  // a newer header's struct: version 1's fields and one more
struct FuturePlugin {
  YamorOptimizerPlugin v1;
  uint64_t future_field;  // unknown to this loader: must not matter
};
extern "C" YAMOR_OPTIMIZER_EXPORT const YamorOptimizerPlugin* yamor_optimizer_plugin(void) {
  static const FuturePlugin plugin = {
      {YAMOR_OPTIMIZER_ABI_VERSION, sizeof(FuturePlugin), "larger", "2", "t", "d", 0, nullptr,
       &RunNothing},
      0xfeedfacecafebeefull};
  return &plugin.v1;
}
#endif
