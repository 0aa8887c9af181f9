// The CPG oscillator network of thesis section 6.1.1: one phase/amplitude/
// offset oscillator per module, coupled through phase biases.
//
//   dphi_i/dt   = omega_i + sum_j w_ij r_j sin(phi_j - phi_i - varphi_ij)
//   d2r_i/dt2   = a_r (a_r/4 (R_i - r_i) - dr_i/dt)
//   d2x_i/dt2   = a_x (a_x/4 (X_i - x_i) - dx_i/dt)
//   theta_i     = x_i + r_i cos(phi_i)
//
// The limit angles clamp the servo set-point theta_i only; the oscillators
// never see them. The model (Network) is compiled once and immutable; the
// mutable NetworkState is advanced by Step() with classic fixed-step RK4.
//
// Changing parameters while running: compile a new Network from the edited
// RobotConfig and carry the state over with RemapState(). Phase, r and x stay
// continuous (no jump in the set-point); r and x then converge critically
// damped to the new targets R and X, the phase rate changes at once to the
// new omega and couplings.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <utility>
#include <vector>

#include "cpg/robot_config.h"

namespace yamor::cpg {

/// Constants of the oscillator equations that are not per module.
struct NetworkOptions {
  double amplitude_gain = 4.0;  ///< a_r [1/s]: convergence speed of r.
  double offset_gain = 4.0;     ///< a_x [1/s]: convergence speed of x.
};

struct NetworkState;

/// One coupling term of oscillator i's phase equation, in compiled form:
/// weight * r_source * sin(phi_source - phi_i - phase).
struct CompiledLink {
  std::size_t source = 0;  ///< Index of the driving oscillator j.
  double weight = 0.0;     ///< w_ij.
  double phase = 0.0;      ///< Phase bias varphi_ij [rad].
};

/// The compiled, validated oscillator network of one robot configuration.
/// Oscillator indices 0..size()-1 follow the module order of the config.
/// Thread-safety: immutable after Compile(); safe to share between threads.
class Network {
 public:
  /// An empty network (no oscillators); use Compile() for a real one.
  Network() = default;

  /// Compiles `config`. Checks everything the dynamics rely on (it does not
  /// assume Validate() was called): throws yamor::Error kInvalidArgument for a
  /// non-finite value, min_angle > max_angle, a duplicate module id or a bad
  /// option, and kNotFound for a coupling naming an unknown module.
  /// Self-couplings and repeated couplings are accepted (their terms add).
  static Network Compile(const RobotConfig& config, NetworkOptions options = {});

  /// Number of oscillators (= modules).
  std::size_t size() const { return ids_.size(); }
  /// Index of module `id`; throws yamor::Error kNotFound when absent.
  std::size_t IndexOf(ModuleId id) const;
  /// Index of module `id`, or nullopt when absent.
  std::optional<std::size_t> FindIndex(ModuleId id) const;
  /// Module id of oscillator `index`; throws kOutOfRange when index >= size().
  ModuleId IdAt(std::size_t index) const;
  /// Module ids in index order.
  const std::vector<ModuleId>& ids() const { return ids_; }
  /// The module parameters of oscillator `index` as compiled (kOutOfRange
  /// when index >= size()).
  const ModuleParams& params(std::size_t index) const;
  /// The equation constants.
  const NetworkOptions& options() const { return options_; }

  // Per-oscillator accessors below do not check the index (hot path).

  /// Target frequency omega_i = 2 pi speed_i [rad/s].
  double omega(std::size_t index) const { return omega_[index]; }
  /// Target amplitude R_i [rad].
  double target_amplitude(std::size_t index) const { return amplitude_[index]; }
  /// Target offset X_i [rad].
  double target_offset(std::size_t index) const { return offset_[index]; }
  /// Lower set-point limit [rad].
  double min_angle(std::size_t index) const { return min_angle_[index]; }
  /// Upper set-point limit [rad].
  double max_angle(std::size_t index) const { return max_angle_[index]; }
  /// The coupling terms of oscillator `index`'s phase equation, in config order.
  std::span<const CompiledLink> LinksOf(std::size_t index) const {
    return {links_.data() + link_begin_[index],
            link_begin_[index + 1] - link_begin_[index]};
  }
  /// Total number of coupling terms.
  std::size_t link_count() const { return links_.size(); }

  /// The start state: phase 0, r = x = 0, rates 0, every oscillator enabled,
  /// time 0.
  NetworkState InitialState() const;
  /// As InitialState() but with phases drawn uniformly from [0, 2 pi) by a
  /// std::mt19937_64 seeded with `seed` (bit-identical on every platform).
  NetworkState InitialState(std::uint64_t seed) const;

 private:
  NetworkOptions options_;
  std::vector<ModuleId> ids_;
  std::vector<ModuleParams> params_;
  std::vector<std::pair<ModuleId, std::size_t>> index_by_id_;  // sorted by id
  std::vector<double> omega_;
  std::vector<double> amplitude_;
  std::vector<double> offset_;
  std::vector<double> min_angle_;
  std::vector<double> max_angle_;
  std::vector<std::size_t> link_begin_;  // CSR row starts, size() + 1 entries
  std::vector<CompiledLink> links_;
};

/// Work buffers of Step(). Not part of a state's value: a copy starts empty
/// and Step() sizes it on first use, so copying a NetworkState stays cheap.
/// Thread-safety: owned by one NetworkState; never shared.
class StepScratch {
 public:
  StepScratch() = default;
  /// Copies do not carry buffers.
  StepScratch(const StepScratch&) noexcept {}
  /// Keeps this object's own buffers (no reallocation when sizes match).
  StepScratch& operator=(const StepScratch&) noexcept { return *this; }
  StepScratch(StepScratch&&) noexcept = default;             ///< Moves buffers.
  StepScratch& operator=(StepScratch&&) noexcept = default;  ///< Moves buffers.
  ~StepScratch() = default;

  /// Makes room for `oscillators` oscillators (allocates only on growth).
  void Reserve(std::size_t oscillators);
  /// Start of the buffer block (stage state, stage slope, slope sum).
  double* data() { return buffer_.data(); }
  /// Oscillators the buffers currently hold.
  std::size_t capacity() const { return buffer_.size() / kDoublesPerOscillator; }

  /// Doubles per oscillator: 5 state components x (stage, slope, sum).
  static constexpr std::size_t kDoublesPerOscillator = 15;

 private:
  std::vector<double> buffer_;
};

/// The mutable state of a Network: one entry per oscillator in index order.
/// Phases are unwrapped (continuous, not reduced mod 2 pi).
/// Thread-safety: none; a state belongs to one thread at a time.
struct NetworkState {
  double time = 0.0;             ///< Integrated time [s].
  std::vector<double> phase;     ///< phi_i [rad], unwrapped.
  std::vector<double> r;         ///< Amplitude r_i [rad].
  std::vector<double> dr;        ///< dr_i/dt [rad/s].
  std::vector<double> x;         ///< Offset x_i [rad].
  std::vector<double> dx;        ///< dx_i/dt [rad/s].
  /// Per-module CPG enable (module firmware flag). A disabled oscillator
  /// holds its state, emits no set-point, and still drives its neighbours.
  std::vector<bool> enabled;
  StepScratch scratch;           ///< Step()'s buffers; not part of the value.

  /// Number of oscillators held.
  std::size_t size() const { return phase.size(); }
  /// Equality of the values (exact double compare); ignores the scratch.
  friend bool operator==(const NetworkState& a, const NetworkState& b) {
    return a.time == b.time && a.phase == b.phase && a.r == b.r &&
           a.dr == b.dr && a.x == b.x && a.dx == b.dx && a.enabled == b.enabled;
  }
};

/// Advances `state` by one classic RK4 step of size `dt` [s]. Allocation-free
/// once the state's scratch is sized (InitialState() sizes it). Throws
/// yamor::Error kInvalidArgument when dt is not finite and > 0 or when the
/// state does not match the network's size.
void Step(const Network& network, NetworkState& state, double dt);

/// Advances `state` by `duration` [s] in steps of `dt`, the last step shorter
/// when duration is not a multiple of dt. Throws kInvalidArgument for a
/// negative or non-finite duration or a bad dt.
void Integrate(const Network& network, NetworkState& state, double duration,
               double dt);

/// Unclamped oscillator output theta_i = x_i + r_i cos(phi_i) [rad], also for
/// a disabled oscillator. Throws kOutOfRange for a bad index.
double RawOutput(const Network& network, const NetworkState& state,
                 std::size_t index);

/// The servo set-point of oscillator `index`: theta_i clamped to
/// [min_angle, max_angle], or nullopt when the oscillator is disabled.
/// Throws kOutOfRange for a bad index.
std::optional<double> SetPoint(const Network& network, const NetworkState& state,
                               std::size_t index);

/// All set-points in index order into `out` (resized to network.size();
/// no allocation when it already has that size).
void SetPoints(const Network& network, const NetworkState& state,
               std::vector<std::optional<double>>& out);

/// Carries `state` of network `from` over to network `to`: modules present
/// in both keep their phase, r, dr, x, dx and enable flag (matched by id),
/// modules new in `to` start from the initial values; time is kept. Throws
/// kInvalidArgument when `state` does not match `from`.
NetworkState RemapState(const Network& from, const NetworkState& state,
                        const Network& to);

}  // namespace yamor::cpg
