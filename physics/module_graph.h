// The module graph (cpg::ModuleGraph, thesis 7.4.1) of a morphology: its
// connected modules, their placed orientations and its connections.
#pragma once

#include <utility>
#include <vector>

#include "cpg/module_graph.h"
#include "physics/morphology.h"

namespace yamor::physics {

/// The graph of `morphology`'s connected modules (spares are left out) with
/// each module's body orientation in the robot frame and up = +z. Modules
/// listed in `activity` take that driven/passive flag (the last entry for an
/// id wins); the rest are driven.
/// Thread-safe.
cpg::ModuleGraph ModuleGraphOf(const Morphology& morphology,
                               const std::vector<std::pair<int, bool>>& activity = {});

}  // namespace yamor::physics
