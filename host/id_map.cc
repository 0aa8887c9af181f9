#include "host/id_map.h"

#include <cctype>
#include <charconv>
#include <set>
#include <string_view>

#include "common/status.h"

namespace yamor::host {
namespace {

constexpr int kMaxId = 254;

void CheckId(int id, std::string_view what) {
  if (id < 0 || id > kMaxId) {
    throw Error(StatusCode::kInvalidArgument,
                "id map: " + std::string(what) + " id " + std::to_string(id) +
                    " is outside 0..254");
  }
}

std::string_view Trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

int ParseInt(std::string_view text, std::string_view entry) {
  text = Trim(text);
  int value = 0;
  auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (text.empty() || ec != std::errc() || ptr != text.data() + text.size()) {
    throw Error(StatusCode::kInvalidArgument,
                "id map entry '" + std::string(entry) + "' is not real:sim");
  }
  return value;
}

}  // namespace

IdMap::IdMap(std::map<int, int> real_to_sim) : real_to_sim_(std::move(real_to_sim)) {
  for (const auto& [real, sim] : real_to_sim_) {
    CheckId(real, "real");
    CheckId(sim, "simulation");
    if (!sim_to_real_.emplace(sim, real).second) {
      throw Error(StatusCode::kInvalidArgument,
                  "id map: real ids " + std::to_string(sim_to_real_.at(sim)) + " and " +
                      std::to_string(real) + " both map to simulation id " + std::to_string(sim));
    }
  }
}

int IdMap::ToSim(int real) const {
  auto it = real_to_sim_.find(real);
  return it == real_to_sim_.end() ? real : it->second;
}

int IdMap::ToReal(int sim) const {
  auto it = sim_to_real_.find(sim);
  return it == sim_to_real_.end() ? sim : it->second;
}

void IdMap::CheckInjective(const std::vector<int>& real_ids) const {
  std::map<int, int> seen;  // sim -> real
  for (int real : real_ids) {
    const int sim = ToSim(real);
    auto [it, inserted] = seen.emplace(sim, real);
    if (!inserted && it->second != real) {
      throw Error(StatusCode::kInvalidArgument,
                  "id map sends real ids " + std::to_string(it->second) + " and " +
                      std::to_string(real) + " to the same simulation id " + std::to_string(sim));
    }
  }
}

std::string IdMap::ToString() const {
  std::string out;
  for (const auto& [real, sim] : real_to_sim_) {
    if (!out.empty()) out += ',';
    out += std::to_string(real) + ':' + std::to_string(sim);
  }
  return out;
}

IdMap ParseIdMap(const std::string& text) {
  std::map<int, int> pairs;
  std::string_view rest = text;
  while (!Trim(rest).empty()) {
    const std::size_t comma = rest.find(',');
    const std::string_view entry = Trim(rest.substr(0, comma));
    rest = comma == std::string_view::npos ? std::string_view() : rest.substr(comma + 1);
    const std::size_t colon = entry.find(':');
    if (colon == std::string_view::npos) {
      throw Error(StatusCode::kInvalidArgument,
                  "id map entry '" + std::string(entry) + "' is not real:sim");
    }
    const int real = ParseInt(entry.substr(0, colon), entry);
    const int sim = ParseInt(entry.substr(colon + 1), entry);
    if (!pairs.emplace(real, sim).second) {
      throw Error(StatusCode::kInvalidArgument,
                  "id map maps real id " + std::to_string(real) + " twice");
    }
  }
  return IdMap(std::move(pairs));
}

}  // namespace yamor::host
