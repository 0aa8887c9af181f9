// The host-side frame builder: the SNP frames that bring a robot from
// power-on to running a configuration, in the order a host sends them. Moved
// here from bridge/ (issue 11): building frames is the host's job; the
// emulated robot only answers them.
#pragma once

#include <vector>

#include "cpg/robot_config.h"
#include "proto/snp/frame.h"

namespace yamor::host {

/// True for one of the thesis's inactive modules: a configured module whose
/// oscillator is all zero (amplitude, offset and speed 0). It is configured
/// (it may be the master and relay links) but its servo stays unpowered, a
/// free hinge, instead of holding 0 against the robot (appendix A.4's wheel).
bool IsInactive(const cpg::ModuleParams& module);

/// The frames that bring a robot from power-on to running `config`, in the
/// order a host sends them: bluetooth links in tree order (parent first), then
/// per module its oscillator, limits, couplings (cleared, then set), and
/// finally Control(uart on, cpg on, motors on — off for an inactive module,
/// see IsInactive) to each module. Ids in `config` are used as they are (no
/// id mapping; SnpLink::Configure maps them). Pure; safe from any thread.
std::vector<snp::Frame> ConfigurationFrames(const cpg::RobotConfig& config);

}  // namespace yamor::host
