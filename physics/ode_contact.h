// The ODE solver and contact settings of the world, shared with the bench's
// naive baseline world so both simulate the same contact model. Includes ODE:
// only for code that links ODE itself (physics/, tools/bench).
#pragma once

#include <ode/ode.h>

namespace yamor::physics {

/// Most contact points generated per colliding geom pair.
inline constexpr int kMaxContactsPerPair = 4;
/// Global joint ERP. With kJointCfm, a little softness keeps kinematic loops
/// (the wheel), whose hinge constraints are partly redundant, well conditioned.
inline constexpr double kJointErp = 0.2;
/// Global joint CFM (see kJointErp).
inline constexpr double kJointCfm = 1e-6;

/// Collides geoms a and b and attaches one soft, pyramid-friction contact
/// joint (friction `mu`, contact `soft_erp`/`soft_cfm`) per contact point to
/// their bodies, in `group`. Returns the number of contacts.
inline int AddContactJoints(dWorldID world, dJointGroupID group, dGeomID a, dGeomID b, double mu,
                            double soft_erp, double soft_cfm) {
  dContactGeom found[kMaxContactsPerPair];
  const int count = dCollide(a, b, kMaxContactsPerPair, found, sizeof(dContactGeom));
  for (int i = 0; i < count; ++i) {
    dContact contact{};
    contact.geom = found[i];
    contact.surface.mode = dContactApprox1 | dContactSoftERP | dContactSoftCFM;
    contact.surface.mu = mu;
    contact.surface.soft_erp = soft_erp;
    contact.surface.soft_cfm = soft_cfm;
    dJointID joint = dJointCreateContact(world, group, &contact);
    dJointAttach(joint, dGeomGetBody(a), dGeomGetBody(b));
  }
  return count;
}

}  // namespace yamor::physics
