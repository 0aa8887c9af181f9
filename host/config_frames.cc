#include "host/config_frames.h"

#include <deque>
#include <map>

#include "proto/snp/messages.h"

namespace yamor::host {

using snp::Address;

bool IsInactive(const cpg::ModuleParams& module) {
  return module.amplitude == 0.0 && module.offset == 0.0 && module.speed == 0.0;
}

std::vector<snp::Frame> ConfigurationFrames(const cpg::RobotConfig& config) {
  std::vector<snp::Frame> frames;
  const Address host = Address::Host();
  auto to_module = [](int id) { return Address::Module(static_cast<uint8_t>(id)); };

  // Bluetooth links in tree order: a parent is linked before its children.
  std::map<int, std::vector<int>> children;
  for (const auto& [child, parent] : config.bluetooth_parent) children[parent].push_back(child);
  std::deque<int> queue{config.master_id};
  while (!queue.empty()) {
    const int parent = queue.front();
    queue.pop_front();
    for (int child : children[parent]) {
      frames.push_back(snp::MakeFrame(host, to_module(parent),
                                      snp::ConnectRequest{.child = static_cast<uint8_t>(child)}));
      queue.push_back(child);
    }
  }
  for (const cpg::ModuleParams& m : config.modules) {
    frames.push_back(snp::MakeFrame(host, to_module(m.id),
                                    snp::SetOscillator{.amplitude = static_cast<float>(m.amplitude),
                                                       .offset = static_cast<float>(m.offset),
                                                       .speed = static_cast<float>(m.speed)}));
    frames.push_back(snp::MakeFrame(host, to_module(m.id),
                                    snp::SetLimits{.min_angle = static_cast<float>(m.min_angle),
                                                   .max_angle = static_cast<float>(m.max_angle)}));
    frames.push_back(snp::MakeFrame(host, to_module(m.id), snp::ClearCouplings{}));
    for (const cpg::Coupling& c : config.couplings) {
      if (c.from != m.id) continue;
      frames.push_back(snp::MakeFrame(host, to_module(m.id),
                                      snp::SetCoupling{.to = static_cast<uint8_t>(c.to),
                                                       .phase = static_cast<float>(c.phase),
                                                       .weight = static_cast<float>(c.weight)}));
    }
  }
  for (const cpg::ModuleParams& m : config.modules) {
    frames.push_back(snp::MakeFrame(
        host, to_module(m.id),
        snp::Control{.uart = snp::Tristate::kOn,
                     .cpg = snp::Tristate::kOn,
                     .motors = IsInactive(m) ? snp::Tristate::kOff : snp::Tristate::kOn}));
  }
  return frames;
}

}  // namespace yamor::host
