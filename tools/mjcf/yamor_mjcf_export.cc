// yamor-mjcf-export: writes a YaMoR world/morphology file as a MuJoCo model.
//
//   yamor-mjcf-export --world configs/worlds/quadruped.xml --out quadruped.mjcf.xml
//                     [--time-step 0.001] [--actuator-damping 1.0]
//                     [--contact-time-constant 0.02] [--unpowered 4,0]
//
// See tools/mjcf/mjcf_export.h for the mapping and docs/benchmarks.md for how
// the benchmark uses it.
#include <fstream>
#include <iostream>
#include <string>

#include <CLI/CLI.hpp>

#include "common/log.h"
#include "common/status.h"
#include "physics/morphology.h"
#include "tools/mjcf/mjcf_export.h"

int main(int argc, char** argv) {
  std::string world_path;
  std::string out_path;
  std::string log_level = "info";
  yamor::mjcf::ExportOptions options;
  CLI::App app{"Exports a YaMoR morphology (configs/worlds/*.xml) as a MuJoCo MJCF model: "
               "one body per rigid group, the central module's group free, servo hinges "
               "with position actuators."};
  app.add_option("--world", world_path, "morphology XML (configs/worlds/...)")->required();
  app.add_option("--out", out_path, "output MJCF file")->required();
  app.add_option("--time-step", options.world.time_step, "simulation step [s]")
      ->capture_default_str();
  app.add_option("--actuator-damping", options.actuator_damping,
                 "position actuator kv [N m s/rad]; kp = servo gain * kv")
      ->capture_default_str();
  app.add_option("--contact-time-constant", options.contact_time_constant,
                 "MuJoCo contact solref time constant [s]")
      ->capture_default_str();
  app.add_option("--unpowered", options.unpowered_modules,
                 "ids of modules whose servo is unpowered (no actuator; gearbox friction only)")
      ->delimiter(',');
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error, off")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  try {
    yamor::SetLogLevel(log_level);
    const yamor::physics::Morphology morphology = yamor::physics::Morphology::LoadFile(world_path);
    yamor::mjcf::ExportSummary summary;
    const std::string xml = yamor::mjcf::ExportMjcf(morphology, options, &summary);
    std::ofstream out(out_path);
    out << xml;
    out.close();
    if (!out) {
      throw yamor::Error(yamor::StatusCode::kNotFound, "cannot write --out file '" + out_path + "'");
    }
    yamor::Log().info("{}: {} bodies, {} servo hinges, step {} s -> {}", world_path,
                      summary.bodies, summary.hinges, options.world.time_step, out_path);
    for (int id : summary.skipped_hinges) {
      yamor::Log().warn("module {}: its hinge closes a kinematic loop; left out (MuJoCo "
                        "needs a tree)", id);
    }
    for (int id : summary.locked_servos) {
      yamor::Log().warn("module {}: body and handle are rigidly connected; no joint", id);
    }
    return 0;
  } catch (const yamor::Error& error) {
    std::cerr << "yamor-mjcf-export: " << yamor::StatusCodeName(error.code()) << ": "
              << error.what() << "\n";
  } catch (const std::exception& error) {
    std::cerr << "yamor-mjcf-export: " << error.what() << "\n";
  }
  return 1;
}
