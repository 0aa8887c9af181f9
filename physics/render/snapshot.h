// Conversion between a Scene and the scene snapshot SNP carries
// (proto/snp/scene.h, docs/snp.md "Scene snapshot"): the bridge answers
// ReadScene with ToSnapshot(bridge::SceneOf(world)); the host renders
// FromSnapshot of what it read, with module ids mapped back to real ids.
#pragma once

#include <functional>

#include "physics/render/scene.h"
#include "proto/snp/scene.h"

namespace yamor::render {

/// The snapshot of `scene` (float32 poses). Throws yamor::Error
/// (INVALID_ARGUMENT) for a module id outside 0..254 or duplicated, and the
/// snapshot codec's errors for values it cannot carry.
snp::SceneSnapshot ToSnapshot(const Scene& scene);

/// The scene of `snapshot`; `module_id` maps each wire id to the id shown
/// (identity when empty).
Scene FromSnapshot(const snp::SceneSnapshot& snapshot,
                   const std::function<int(int)>& module_id = {});

}  // namespace yamor::render
