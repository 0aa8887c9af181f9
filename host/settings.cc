#include "host/settings.h"

#include <cmath>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

#include <toml++/toml.h>

#include "common/format.h"
#include "common/status.h"
#include "host/id_map.h"

namespace yamor::host {
namespace {

std::string Where(std::string_view source, const toml::node& node) {
  return std::string(source) + ":" + std::to_string(node.source().begin.line) + ": ";
}

[[noreturn]] void Bad(std::string_view source, const toml::node& node, const std::string& what) {
  throw Error(StatusCode::kInvalidArgument, Where(source, node) + what);
}

std::string GetString(std::string_view source, const toml::node& node, std::string_view key) {
  if (!node.is_string()) Bad(source, node, std::string(key) + " must be a string");
  return *node.value<std::string>();
}

int64_t GetInteger(std::string_view source, const toml::node& node, std::string_view key,
                   int64_t lo, int64_t hi) {
  if (!node.is_integer()) Bad(source, node, std::string(key) + " must be an integer");
  const int64_t v = *node.value<int64_t>();
  if (v < lo || v > hi) {
    Bad(source, node, std::string(key) + " = " + std::to_string(v) + " is outside [" +
                          std::to_string(lo) + ", " + std::to_string(hi) + "]");
  }
  return v;
}

double GetNumber(std::string_view source, const toml::node& node, std::string_view key) {
  if (!node.is_number()) Bad(source, node, std::string(key) + " must be a number");
  const double v = *node.value<double>();
  if (!std::isfinite(v)) Bad(source, node, std::string(key) + " must be finite");
  return v;
}

std::string Quote(const std::string& s) {
  std::ostringstream out;
  out << toml::value<std::string>(s);
  return out.str();
}

}  // namespace

Settings ParseSettingsToml(std::string_view text, std::string_view source) {
  toml::table table;
  try {
    table = toml::parse(text, source);
  } catch (const toml::parse_error& e) {
    throw Error(StatusCode::kInvalidArgument,
                std::string(source) + ":" + std::to_string(e.source().begin.line) + ": " +
                    std::string(e.description()));
  }
  Settings s;
  for (const auto& [key_, node] : table) {
    const std::string key(key_.str());
    if (key == "listen") {
      s.listen = GetString(source, node, key);
    } else if (key == "backend") {
      s.backend = GetString(source, node, key);
    } else if (key == "device") {
      s.device = GetString(source, node, key);
    } else if (key == "baud") {
      s.baud = static_cast<int>(GetInteger(source, node, key, 1, 100000000));
    } else if (key == "data_bits") {
      s.data_bits = static_cast<int>(GetInteger(source, node, key, 0, 64));
    } else if (key == "parity") {
      s.parity = GetString(source, node, key);
    } else if (key == "stop_bits") {
      s.stop_bits = static_cast<int>(GetInteger(source, node, key, 0, 64));
    } else if (key == "flow_control") {
      s.flow_control = GetString(source, node, key);
    } else if (key == "hello_timeout") {
      s.hello_timeout = GetNumber(source, node, key);
    } else if (key == "reply_timeout") {
      s.reply_timeout = GetNumber(source, node, key);
    } else if (key == "world") {
      s.world = GetString(source, node, key);
    } else if (key == "config") {
      s.config = GetString(source, node, key);
    } else if (key == "workers") {
      s.workers = static_cast<unsigned>(GetInteger(source, node, key, 0, 1024));
    } else if (key == "id_map") {
      if (node.is_string()) {
        s.id_map = *node.value<std::string>();
      } else if (const toml::table* map = node.as_table()) {
        std::string text_map;
        for (const auto& [real, sim] : *map) {
          const int64_t sim_id = GetInteger(source, sim, "id_map." + std::string(real.str()), 0, 254);
          if (!text_map.empty()) text_map += ',';
          text_map.append(real.str()).append(":").append(std::to_string(sim_id));
        }
        s.id_map = text_map;
      } else {
        Bad(source, node, "id_map must be a table of real = sim ids or a \"real:sim,...\" string");
      }
      try {
        ParseIdMap(s.id_map);
      } catch (const Error& e) {
        Bad(source, node, e.what());
      }
    } else if (key == "master") {
      s.master = static_cast<int>(GetInteger(source, node, key, 0, 254));
    } else if (key == "led_tracker") {
      s.led_tracker = GetString(source, node, key);
    } else if (key == "tracker_calibration") {
      s.tracker_calibration = GetString(source, node, key);
    } else if (key == "tracker_max_age") {
      s.tracker_max_age = GetNumber(source, node, key);
    } else if (key == "position_source") {
      s.position_source = GetString(source, node, key);
    } else if (key == "log_level") {
      s.log_level = GetString(source, node, key);
    } else if (key == "max_concurrent_calls") {
      s.max_concurrent_calls = static_cast<unsigned>(GetInteger(source, node, key, 1, 100000));
    } else if (key == "link_timeout") {
      s.link_timeout = GetNumber(source, node, key);
    } else if (key == "link_retries") {
      s.link_retries = static_cast<int>(GetInteger(source, node, key, 0, 10));
    } else if (key == "free_run") {
      s.free_run = GetNumber(source, node, key);
    } else if (key == "record") {
      s.record = GetString(source, node, key);
    } else if (key == "seed") {
      s.seed = static_cast<uint64_t>(
          GetInteger(source, node, key, 0, std::numeric_limits<int64_t>::max()));
    } else {
      Bad(source, node, "unknown setting '" + key + "'");
    }
  }
  try {
    ValidateSettings(s);
  } catch (const Error& e) {
    throw Error(e.code(), std::string(source) + ": " + e.what());
  }
  return s;
}

Settings LoadSettingsFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error(StatusCode::kNotFound, "cannot read settings file " + path);
  std::ostringstream text;
  text << in.rdbuf();
  return ParseSettingsToml(text.str(), path);
}

void ValidateSettings(const Settings& s) {
  const std::size_t colon = s.listen.rfind(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == s.listen.size()) {
    throw Error(StatusCode::kInvalidArgument, "listen address '" + s.listen + "' is not ADDR:PORT");
  }
  if (s.backend != "sim" && s.backend != "serial") {
    throw Error(StatusCode::kInvalidArgument,
                "backend '" + s.backend + "' is not 'sim' or 'serial'");
  }
  if (s.backend == "serial" && s.device.empty()) {
    throw Error(StatusCode::kInvalidArgument,
                "backend 'serial' needs a device (a path such as /dev/ttyUSB0, or "
                "tcp://HOST:PORT)");
  }
  // The serial values are checked whatever the backend, so a typo in a file
  // shows at once and not when someone switches to the serial backend (a
  // placeholder stands in for the sim backend's unused, empty device).
  SerialOptions serial = SerialOptionsOf(s);
  if (serial.device.empty()) serial.device = "(none)";
  ValidateSerialOptions(serial);
  if (!(s.reply_timeout > 0.0 && s.reply_timeout <= 120.0)) {
    throw Error(StatusCode::kOutOfRange, "reply_timeout " + FormatDouble(s.reply_timeout) +
                                             " s is outside (0, 120]");
  }
  ParseIdMap(s.id_map);
  if (s.master && (*s.master < 0 || *s.master > 254)) {
    throw Error(StatusCode::kOutOfRange, "master " + std::to_string(*s.master) + " is outside 0..254");
  }
  if (!(s.link_timeout > 0.0 && s.link_timeout <= 120.0)) {
    throw Error(StatusCode::kOutOfRange, "link_timeout must be in (0, 120] s");
  }
  if (!(s.tracker_max_age > 0.0 && s.tracker_max_age <= 60.0)) {
    throw Error(StatusCode::kOutOfRange, "tracker_max_age " + FormatDouble(s.tracker_max_age) +
                                             " s is outside (0, 60]");
  }
  if (s.position_source != "auto" && s.position_source != "tracker") {
    throw Error(StatusCode::kInvalidArgument,
                "position_source \"" + s.position_source + "\" is neither auto nor tracker");
  }
  if (s.position_source == "tracker" && s.led_tracker.empty()) {
    throw Error(StatusCode::kInvalidArgument,
                "position_source tracker needs led_tracker HOST:PORT (--led-tracker)");
  }
  if (s.link_retries < 0 || s.link_retries > 10) {
    throw Error(StatusCode::kOutOfRange,
                "link_retries " + std::to_string(s.link_retries) + " is outside 0..10");
  }
  if (!(s.free_run >= 0.0 && s.free_run <= 100.0)) {
    throw Error(StatusCode::kOutOfRange, "free_run must be in [0, 100]");
  }
  if (s.max_concurrent_calls < 1) {
    throw Error(StatusCode::kOutOfRange, "max_concurrent_calls must be >= 1");
  }
  static const std::set<std::string> kLevels = {"trace", "debug", "info",    "warn",
                                                "error", "critical", "off"};
  if (kLevels.count(s.log_level) == 0) {
    throw Error(StatusCode::kInvalidArgument, "log_level '" + s.log_level +
                                                  "' is not trace, debug, info, warn, error, "
                                                  "critical or off");
  }
}

SerialOptions SerialOptionsOf(const Settings& s) {
  SerialOptions options;
  options.device = s.device;
  options.baud = s.baud;
  options.data_bits = s.data_bits;
  options.parity = ParseParity(s.parity);
  options.stop_bits = s.stop_bits;
  options.flow_control = ParseFlowControl(s.flow_control);
  options.hello_timeout = s.hello_timeout;
  return options;
}

std::string SettingsToToml(const Settings& s) {
  std::ostringstream out;
  out << "# yamord settings (effective values)\n";
  out << "listen = " << Quote(s.listen) << "\n";
  out << "backend = " << Quote(s.backend) << "  # sim or serial\n";
  out << "device = " << Quote(s.device)
      << "  # serial: /dev/ttyUSB0, /dev/rfcomm0, tcp://HOST:PORT\n";
  out << "baud = " << s.baud << "\n";
  out << "data_bits = " << s.data_bits << "\n";
  out << "parity = " << Quote(s.parity) << "  # none, odd, even\n";
  out << "stop_bits = " << s.stop_bits << "\n";
  out << "flow_control = " << Quote(s.flow_control) << "  # none, software, hardware\n";
  out << "hello_timeout = " << toml::value<double>(s.hello_timeout) << "\n";
  out << "reply_timeout = " << toml::value<double>(s.reply_timeout) << "\n";
  out << "world = " << Quote(s.world) << "  # \"\" = quadruped\n";
  out << "config = " << Quote(s.config) << "  # \"\" = the world's built-in configuration\n";
  out << "workers = " << s.workers << "  # 0 = core count\n";
  if (s.master) {
    out << "master = " << *s.master << "\n";
  } else {
    out << "# master = 4  # unset: the configuration's master node\n";
  }
  out << "led_tracker = " << Quote(s.led_tracker) << "\n";
  out << "tracker_calibration = " << Quote(s.tracker_calibration) << "\n";
  out << "tracker_max_age = " << toml::value<double>(s.tracker_max_age) << "\n";
  out << "position_source = " << Quote(s.position_source) << "  # auto or tracker\n";
  out << "log_level = " << Quote(s.log_level) << "\n";
  out << "max_concurrent_calls = " << s.max_concurrent_calls << "\n";
  out << "link_timeout = " << toml::value<double>(s.link_timeout) << "\n";
  out << "link_retries = " << s.link_retries << "\n";
  out << "free_run = " << toml::value<double>(s.free_run) << "\n";
  out << "seed = " << s.seed << "\n";
  out << "record = " << Quote(s.record) << "  # \"\" = no recording of SNP frames\n";
  out << "\n[id_map]  # real id = simulation id\n";
  const IdMap id_map = ParseIdMap(s.id_map);
  for (const auto& [real, sim] : id_map.pairs()) {
    out << real << " = " << sim << "\n";
  }
  return out.str();
}

}  // namespace yamor::host
