// Construction of the in-process simulation backend without its headers: the
// driver and the Evaluate workers build a SimBackend through this and then
// know it only as a Backend that speaks SNP (DESIGN.md, "One SNP path").
#pragma once

#include <cstdint>
#include <memory>

#include "host/backend.h"
#include "physics/morphology.h"

namespace yamor::host {

/// What a new simulated robot is built with.
struct SimulationOptions {
  double time_step = 0.0;  ///< Physics step [s]; 0 = DefaultSimulationTimeStep().
  uint64_t seed = 0;       ///< World and oscillator-phase seed.
  int master = -1;         ///< Master node (simulation id); < 0: the central module.
};

/// The physics world's default step [s].
double DefaultSimulationTimeStep();

/// A SimBackend (world at t = 0, every module at power-on). Thread-safe:
/// backends share nothing.
std::unique_ptr<Backend> MakeSimBackend(physics::Morphology morphology,
                                        const SimulationOptions& options);

}  // namespace yamor::host
