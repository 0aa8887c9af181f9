// Lifelong scenarios (configs/lifelong/*.toml): a world, a starting gait,
// default runner options, and changes that happen to the robot at given
// robot times (a transformation script, turning over, the ground, defects).
// The changes are made through the daemon's API like any user would; the
// runner learns of them only as the robot does (events, velocity,
// accelerometers).
//
//   description = "7.5.1: ..."
//   world = "quadruped"              # built-in world, or a morphology file (.xml)
//   config = "../optimize/quadruped-7.xml"   # paths are relative to this file
//   seed = 1
//   [options]                        # yamor-lifelong options; the command line wins
//   max-time = 600
//   set = ["max_evaluations=40"]
//   [[change]]
//   at = 120                         # robot time [s]
//   do = "script"                    # script | upside_down | ground | motor_defect |
//   file = "../scripts/quadruped-transform.xml"   # module_defect | disconnect | connect
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "optimizer-plugins/framework/host_rpc.h"

namespace yamor::lifelong {

/// One scheduled change.
struct ScenarioChange {
  double at = 0;            ///< Robot time [s].
  std::string action;       ///< script, upside_down, ground, motor_defect, module_defect, disconnect, connect.
  int line = 0;             ///< Line in the scenario file.
  std::string script_xml;   ///< script: the script's text.
  std::string file;         ///< script: the file it came from.
  int module = -1;          ///< motor_defect, module_defect, disconnect: the module; connect: the one that moves.
  std::string defect;       ///< motor_defect: "limp", "stuck" or "ok".
  bool defective = true;    ///< module_defect: set (true) or repair (false).
  std::optional<double> friction;         ///< ground.
  std::optional<double> slope;            ///< ground [rad].
  std::optional<double> slope_direction;  ///< ground [rad].
  std::string from_connector = "front";   ///< connect.
  int to = -1;                            ///< connect: the module it attaches to.
  std::string to_connector = "rear";      ///< connect.
  double angle = 0;                       ///< connect [degrees].

  /// "ground friction 0.2 at 120 s"-style summary.
  std::string Describe() const;
};

/// A loaded scenario file.
struct Scenario {
  std::string path;             ///< The file.
  std::string description;      ///< What it shows.
  std::string world;            ///< Built-in world name ("" with morphology_xml).
  std::string morphology_xml;   ///< A morphology file's text (world given as a file).
  std::string config_path;      ///< The starting gait (resolved path).
  std::uint64_t seed = 0;       ///< The world's seed.
  /// Runner options: (long option name without "--", values).
  std::vector<std::pair<std::string, std::vector<std::string>>> options;
  std::vector<ScenarioChange> changes;  ///< Sorted by time.

  /// Reads and checks `path`. Throws yamor::Error kNotFound for a missing
  /// file (the scenario or one it names), kInvalidArgument naming file:line
  /// and the key for anything malformed.
  static Scenario Load(const std::string& path);
};

/// Plays a scenario on one daemon.
///
/// Thread safety: one thread at a time.
class ScenarioPlayer {
 public:
  /// `host` outlives the player; `on_change` hears of every change made
  /// (robot time, the change).
  ScenarioPlayer(Scenario scenario, client::HostClient& host, double rpc_deadline,
                 std::function<void(double, const ScenarioChange&)> on_change = {});

  /// Opens the scenario's world (OpenSimulation) with its seed and
  /// `config_xml`, the life's starting gait. Without one the daemon keeps its
  /// current configuration, which a previous life may have left driving a
  /// module this world has free (an inserted one): refused.
  void Setup(const std::string& config_xml);
  /// Makes every change due at `robot_time` that was not made yet; true when
  /// it made one. A refused change throws yamor::Error by the rule of
  /// host_rpc.h, naming the change and its line.
  bool ApplyDue(double robot_time);
  /// Changes not made yet.
  std::size_t pending() const { return scenario_.changes.size() - next_; }
  /// The scenario.
  const Scenario& scenario() const { return scenario_; }

 private:
  void Apply(const ScenarioChange& change);

  Scenario scenario_;
  client::HostClient& host_;
  double deadline_;
  std::function<void(double, const ScenarioChange&)> on_change_;
  std::size_t next_ = 0;
};

}  // namespace yamor::lifelong
