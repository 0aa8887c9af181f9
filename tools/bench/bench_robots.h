// Robots and gaits the simulation benchmarks share (physics_bench,
// physics_accuracy): thesis Table 6.1's random quadruped gaits and snakes of
// any length built like configs/worlds/snake.xml.
#pragma once

#include <cstdint>

#include "cpg/network.h"
#include "physics/morphology.h"

namespace yamor::bench {

/// A quadruped gait with thesis Table 6.1's seven free parameters drawn
/// uniformly inside their bounds (seeded) on the network of `base`
/// (configs/robots/quadruped.xml). Thread-safety: pure function.
cpg::RobotConfig Table61Gait(const cpg::RobotConfig& base, std::uint64_t seed);

/// A snake of n >= 2 modules as configs/worlds/snake.xml builds it: passive
/// head 0, module i's front (handle) screwed into the rear of module i-1.
physics::Morphology SnakeMorphology(int n);

/// configs/robots/snake.xml generalised to n modules: head passive, chain
/// couplings +π/2 rearwards and −π/2 forwards, amplitude 0.6 rad, 0.6 Hz.
cpg::RobotConfig SnakeConfig(int n);

}  // namespace yamor::bench
