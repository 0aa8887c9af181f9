// yamord's settings (thesis C.1): listen address, backend, world and
// configuration opened at start, Evaluate workers, id mapping, master node,
// LED tracker address, recording file. Read from a TOML file; command-line flags override.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "host/serial_backend.h"

namespace yamor::host {

/// Every daemon setting, with its default. Plain value.
struct Settings {
  std::string listen = "127.0.0.1:2224";  ///< gRPC address ADDR:PORT (port 0 = ephemeral).
  std::string backend = "sim";  ///< "sim" (in-process simulation) or "serial" (`device`).
  std::string device;           ///< Serial backend: device path or tcp://HOST:PORT.
  int baud = 115200;         ///< Serial line rate [bit/s].
  int data_bits = 8;         ///< Serial data bits, 5..8.
  std::string parity = "none";        ///< Serial parity: none, odd, even.
  int stop_bits = 1;                  ///< Serial stop bits, 1 or 2.
  std::string flow_control = "none";  ///< Serial flow control: none, software, hardware.
  double hello_timeout = 0.3;  ///< Wait for the hello's answer [s]; silence = a real robot.
  double reply_timeout = 1.0;  ///< Wait for a module's or the bridge's reply on a serial link [s].
  std::string world;         ///< Built-in world name or morphology file; "" = quadruped.
  std::string config;        ///< Robot configuration file; "" = the world's built-in one.
  unsigned workers = 0;      ///< Evaluate worker threads; 0 = the core count.
  std::string id_map;        ///< Real -> simulation ids, "real:sim,real:sim".
  std::optional<int> master; ///< Expected master node (0..254).
  std::string led_tracker;   ///< LED tracker (CamApp) HOST:PORT; "" = none (docs/camapp.md).
  std::string tracker_calibration;  ///< Camera calibration file of the LED tracker.
  double tracker_max_age = 0.5;     ///< Oldest tracker sample RobotPosition accepts [s].
  /// Where RobotPosition comes from: "auto" (the simulation's own position,
  /// the tracker on a real robot) or "tracker" (the tracker on a simulation too).
  std::string position_source = "auto";
  std::string log_level = "info";      ///< trace, debug, info, warn, error, critical, off.
  unsigned max_concurrent_calls = 64;  ///< Calls served at once; more get RESOURCE_EXHAUSTED.
  double link_timeout = 2.0;           ///< ConnectRobot per-link timeout [s].
  int link_retries = 2;                ///< ConnectRobot retries of a link that missed (0..10).
  double free_run = 0.0;               ///< Free-run real-time factor at start; 0 = off.
  uint64_t seed = 0;                   ///< Seed of the world opened at start.
  std::string record;  ///< Recorded-session file (docs/snp.md) every SNP frame goes to; "" = none.
};

/// Parses TOML settings; keys not set keep their defaults. INVALID_ARGUMENT
/// naming `source` and the line for malformed TOML, unknown keys or values
/// of the wrong type or range.
Settings ParseSettingsToml(std::string_view text, std::string_view source);

/// Reads a TOML settings file: NOT_FOUND when it cannot be read, else as
/// ParseSettingsToml.
Settings LoadSettingsFile(const std::string& path);

/// The settings as TOML (every key, defaults included); parsing the result
/// gives the same settings.
std::string SettingsToToml(const Settings& settings);

/// Checks values that do not depend on the file format (ranges, id map
/// syntax, listen address shape, serial line values even when the backend is
/// "sim"); throws INVALID_ARGUMENT / OUT_OF_RANGE naming the key and value.
void ValidateSettings(const Settings& settings);

/// The SerialBackend options of validated `settings` (device and line values,
/// hello timeout).
SerialOptions SerialOptionsOf(const Settings& settings);

}  // namespace yamor::host
