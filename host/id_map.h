// Real <-> simulation module ids (thesis C.1): module ids of the physical
// robot need not match the simulation's, so the settings may map them. Ids
// not in the map are the same on both sides.
#pragma once

#include <map>
#include <string>
#include <vector>

namespace yamor::host {

/// A bijective mapping of real ids to simulation ids (0..254 each).
/// Thread-safety: immutable after construction; safe to share.
class IdMap {
 public:
  /// The identity.
  IdMap() = default;
  /// Maps real -> simulation; throws yamor::Error(INVALID_ARGUMENT) for ids
  /// outside 0..254 or two real ids mapped to one simulation id.
  explicit IdMap(std::map<int, int> real_to_sim);

  /// The simulation id of real module `real`.
  int ToSim(int real) const;
  /// The real id of simulation module `sim`.
  int ToReal(int sim) const;
  /// Throws INVALID_ARGUMENT when two of `real_ids` land on one simulation
  /// id (an unmapped id colliding with a mapped one).
  void CheckInjective(const std::vector<int>& real_ids) const;
  /// True for the identity.
  bool empty() const { return real_to_sim_.empty(); }
  /// The explicit pairs (real -> simulation).
  const std::map<int, int>& pairs() const { return real_to_sim_; }
  /// "0:10,1:11" (the --id-map syntax); "" for the identity.
  std::string ToString() const;

 private:
  std::map<int, int> real_to_sim_;
  std::map<int, int> sim_to_real_;
};

/// Parses "real:sim,real:sim" (spaces allowed); throws INVALID_ARGUMENT
/// naming the bad entry.
IdMap ParseIdMap(const std::string& text);

}  // namespace yamor::host
