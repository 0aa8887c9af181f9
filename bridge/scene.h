// The scene of a simulated world as the renderer draws it: the bridge's
// answer to ReadScene (docs/snp.md) and the input of in-process rendering.
#pragma once

#include "physics/render/scene.h"
#include "physics/world.h"

namespace yamor::bridge {

/// The current state of `world` as a render::Scene: every module in the
/// world (put-away modules left out) with its body and handle pose and
/// simulation id, the central module, defects, loose modules, the module's
/// shape (physics::ModuleBoxes), the LED on the central module's top face,
/// the slope (from gravity), the world's static boxes and the time. Throws yamor::Error
/// (FAILED_PRECONDITION) when the world is diverged: its poses are not to be
/// trusted.
render::Scene SceneOf(const physics::World& world);

}  // namespace yamor::bridge
