// Transformation scripts (thesis C.2.7): a <script> of <connect>,
// <disconnect> and <pause> commands run against a World.
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "physics/morphology.h"

namespace yamor::physics {

class World;

/// One command of a transformation script.
struct ScriptCommand {
  /// What the command does.
  enum class Kind { kConnect, kDisconnect, kPause };
  Kind kind = Kind::kPause;              ///< Command type.
  MorphologyConnection connection;       ///< kConnect: the link to make (idfrom is placed).
  int id = 0;                            ///< kDisconnect: module to remove and put away.
  int delay_ms = 0;                      ///< kPause: simulated milliseconds to wait.
  int line = 0;                          ///< Source line.
};

/// A parsed transformation script.
/// Thread-safety: immutable after construction; safe to share.
class TransformationScript {
 public:
  /// Loads a script file: kNotFound unreadable, kInvalidArgument (file:line) malformed.
  static TransformationScript LoadFile(const std::filesystem::path& path);
  /// Parses script XML; `source` names it in error messages.
  static TransformationScript Parse(std::string_view xml, std::string_view source);

  /// The commands in order.
  const std::vector<ScriptCommand>& commands() const { return commands_; }
  /// Where the script came from.
  const std::string& source() const { return source_; }

 private:
  std::string source_;
  std::vector<ScriptCommand> commands_;
};

/// Runs `script` against `world`: connections and disconnections happen at
/// once (the world frozen), pauses step the world, calling `before_step` (if
/// set) before every step so a controller can keep driving the servos. Errors
/// from the world are rethrown with their code and the script's file:line.
void RunScript(World& world, const TransformationScript& script,
               const std::function<void(World&)>& before_step = {});

}  // namespace yamor::physics
