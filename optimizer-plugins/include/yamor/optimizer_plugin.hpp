// C++ side of the yamor optimizer plugin ABI (optimizer_plugin.h): a plugin
// is an ordinary class derived from yamor::plugin::Optimizer, exported with
// YAMOR_OPTIMIZER_PLUGIN. Header-only so plugins link nothing of yamor.
//
//   class MyOptimizer : public yamor::plugin::Optimizer {
//    public:
//     void Run(yamor::plugin::Context& context) override {
//       std::vector<double> x = context.Start();
//       while (true) context.Evaluate(x);   // throws Stopped when done
//     }
//   };
//   const YamorField kFields[] = {{"step", "initial step", YAMOR_FIELD_REAL, 0, 1, "0.1", nullptr}};
//   YAMOR_OPTIMIZER_PLUGIN(MyOptimizer, "mine", "1.0.0", "Me", "What it does", kFields)
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "yamor/optimizer_plugin.h"

namespace yamor::plugin {

/// Thrown by Context::Evaluate when the budget is spent or a stop was
/// requested; the plugin lets it propagate (or returns) and the run ends as
/// STOPPED. The evaluations made so far are kept by yamor-optimize.
class Stopped : public std::exception {
 public:
  /// Describes the exception.
  const char* what() const noexcept override { return "optimization stopped"; }
};

/// A running instance's view of yamor-optimize. Not thread-safe: use it
/// only from the thread that entered Optimizer::Run.
class Context {
 public:
  /// Wraps the loader's context; `context` outlives this object. Throws
  /// std::invalid_argument for a missing context or one whose struct_size
  /// is smaller than ABI version 1's (only fields within struct_size are read).
  explicit Context(const YamorOptimizerContext* context) : c_(context) {
    if (context == nullptr) throw std::invalid_argument("no plugin context");
    if (context->struct_size < YAMOR_OPTIMIZER_CONTEXT_V1_SIZE) {
      throw std::invalid_argument(
          "plugin context struct_size " + std::to_string(context->struct_size) +
          " is smaller than ABI version 1's " + std::to_string(YAMOR_OPTIMIZER_CONTEXT_V1_SIZE));
    }
  }

  /// Number of optimized parameters.
  std::size_t Dimension() const { return c_->parameter_count; }
  /// Parameter `i` (name, bounds, start value).
  const YamorParameter& Parameter(std::size_t i) const { return c_->parameters[i]; }
  /// Lower bounds, in parameter order.
  std::vector<double> Lower() const { return Collect(&YamorParameter::min); }
  /// Upper bounds, in parameter order.
  std::vector<double> Upper() const { return Collect(&YamorParameter::max); }
  /// The configuration's values, in parameter order.
  std::vector<double> Start() const { return Collect(&YamorParameter::start); }
  /// This instance's seed.
  std::uint64_t Seed() const { return c_->seed; }

  /// A field's value as text; std::invalid_argument when unknown.
  std::string Field(const char* name) const {
    const char* value = nullptr;
    if (c_->get_field(c_->host, name, &value) != YAMOR_OK || value == nullptr) {
      throw std::invalid_argument(std::string("unknown field '") + name + "'");
    }
    return value;
  }
  /// An INTEGER field (the loader has validated it).
  long long IntField(const char* name) const { return std::stoll(Field(name)); }
  /// A REAL field (the loader has validated it).
  double RealField(const char* name) const { return std::stod(Field(name)); }
  /// A BOOLEAN field (the loader normalizes it to "true"/"false").
  bool BoolField(const char* name) const { return Field(name) == "true"; }

  /// Evaluates points (each Dimension() values inside the bounds) as one
  /// parallel batch; values in submission order. Throws Stopped when the
  /// budget is spent or a stop was requested, std::runtime_error on failure.
  std::vector<double> Evaluate(const std::vector<std::vector<double>>& points) {
    std::vector<double> flat;
    flat.reserve(points.size() * Dimension());
    for (const auto& p : points) {
      if (p.size() != Dimension()) {
        throw std::invalid_argument("a point has " + std::to_string(p.size()) +
                                    " values, the problem has " + std::to_string(Dimension()));
      }
      flat.insert(flat.end(), p.begin(), p.end());
    }
    std::vector<double> values(points.size(), std::numeric_limits<double>::quiet_NaN());
    std::size_t evaluated = 0;
    const std::int32_t status =
        c_->evaluate(c_->host, flat.data(), points.size(), values.data(), &evaluated);
    if (status == YAMOR_STOPPED) throw Stopped();
    if (status != YAMOR_OK) throw std::runtime_error(c_->last_error(c_->host));
    return values;
  }
  /// Evaluates one point.
  double Evaluate(const std::vector<double>& point) { return Evaluate(std::vector<std::vector<double>>{point}).front(); }

  /// Reports progress in [0, 1] (negative: unknown) with a short status.
  void Progress(double fraction, const std::string& status) {
    c_->progress(c_->host, fraction, status.c_str());
  }
  /// Logs at `level` (a YamorLogLevel).
  void Log(YamorLogLevel level, const std::string& message) {
    c_->log(c_->host, level, message.c_str());
  }
  /// Logs at info level.
  void Info(const std::string& message) { Log(YAMOR_LOG_INFO, message); }
  /// True once a stop was requested or the budget is spent.
  bool StopRequested() const { return c_->stop_requested(c_->host) != 0; }

  /// A uniformly distributed 64-bit number from the instance's seeded generator.
  std::uint64_t Random() { return c_->random(c_->host); }
  /// A uniform double in [0, 1).
  double Uniform() { return static_cast<double>(Random() >> 11) * 0x1.0p-53; }

  /// A UniformRandomBitGenerator over Random(), for <random> distributions.
  class Generator {
   public:
    /// The result type.
    using result_type = std::uint64_t;
    /// Draws from `context`.
    explicit Generator(Context& context) : context_(&context) {}
    /// Smallest value.
    static constexpr result_type min() { return 0; }
    /// Largest value.
    static constexpr result_type max() { return std::numeric_limits<result_type>::max(); }
    /// Next number.
    result_type operator()() { return context_->Random(); }

   private:
    Context* context_;
  };

 private:
  std::vector<double> Collect(double YamorParameter::*member) const {
    std::vector<double> out(Dimension());
    for (std::size_t i = 0; i < Dimension(); ++i) out[i] = c_->parameters[i].*member;
    return out;
  }

  const YamorOptimizerContext* c_;
};

/// An optimizer: one object per run, created by the plugin's entry point.
class Optimizer {
 public:
  virtual ~Optimizer() = default;
  /// Runs to convergence, budget or stop. Throw (any std::exception) to fail
  /// with its message; let Stopped propagate.
  virtual void Run(Context& context) = 0;
};

/// Runs one `OptimizerClass` against `context` and maps exceptions to the
/// ABI's status codes. Used by YAMOR_OPTIMIZER_PLUGIN.
template <typename OptimizerClass>
std::int32_t RunOptimizer(const YamorOptimizerContext* raw, char* error, std::size_t error_size) {
  auto fail = [&](const char* message) {
    if (error != nullptr && error_size > 0) std::snprintf(error, error_size, "%s", message);
    return static_cast<std::int32_t>(YAMOR_FAILED);
  };
  try {
    Context context(raw);
    OptimizerClass optimizer;
    optimizer.Run(context);
    return YAMOR_OK;
  } catch (const Stopped&) {
    return YAMOR_STOPPED;
  } catch (const std::exception& e) {
    return fail(e.what());
  } catch (...) {
    return fail("unknown exception");
  }
}

}  // namespace yamor::plugin

/// Defines the plugin's one exported entry symbol for `OptimizerClass`, with
/// `fields_array` a static array of YamorField.
#define YAMOR_OPTIMIZER_PLUGIN(OptimizerClass, name, version, author, description, fields_array) \
  extern "C" YAMOR_OPTIMIZER_EXPORT const YamorOptimizerPlugin* yamor_optimizer_plugin(void) { \
    static const YamorOptimizerPlugin plugin = {                                              \
        YAMOR_OPTIMIZER_ABI_VERSION,                                                          \
        static_cast<std::uint32_t>(sizeof(YamorOptimizerPlugin)),                             \
        name,                                                                                 \
        version,                                                                              \
        author,                                                                               \
        description,                                                                          \
        sizeof(fields_array) / sizeof((fields_array)[0]),                                     \
        fields_array,                                                                         \
        &::yamor::plugin::RunOptimizer<OptimizerClass>};                                      \
    return &plugin;                                                                           \
  }
