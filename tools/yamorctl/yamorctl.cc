#include "tools/yamorctl/yamorctl.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <sstream>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <grpcpp/grpcpp.h>

#include "common/status.h"
#include "optimizer-plugins/framework/host_rpc.h"
#include "physics/render/video.h"
#include "tools/yamorctl/format.h"
#include "tools/yamorctl/tracking.h"
#include "yamor/v1/host.grpc.pb.h"
#include "yamor/v1/lifelong.grpc.pb.h"

namespace yamor::yamorctl {
namespace {

using google::protobuf::Empty;

constexpr char kFooter[] = R"(Output: readable text; with --json the RPC's response as one line of
proto3 JSON (field names as in yamor/v1/host.proto, "{}" for calls without
a result; watch prints one object per update).

Deadlines: every call has one: --timeout (default 10 s); when --timeout is
not given, sleep adds its duration, evaluate its warm-up plus duration,
connect its --link-timeout, script 60 s, snapshot 20 s, record 0.2 s per
frame (plus --seconds with --watch), and watch --count N adds N periods
(a watch without --count has no deadline: stop it with Ctrl-C).

Exit status:
   0  success
   2  usage error: bad command line or unreadable/unwritable local file
      (also UNKNOWN from the daemon)
   otherwise the gRPC status code of the failed call, with the message on
   stderr as "yamorctl: CODE: message":
   1 CANCELLED             8 RESOURCE_EXHAUSTED   12 UNIMPLEMENTED
   3 INVALID_ARGUMENT      9 FAILED_PRECONDITION  13 INTERNAL
   4 DEADLINE_EXCEEDED    11 OUT_OF_RANGE         14 UNAVAILABLE (no daemon)
   5 NOT_FOUND                                    16 UNAUTHENTICATED

Address: --host, else $YAMORCTL_HOST, else 127.0.0.1:2224.)";

// Largest response we accept: a 4096x4096 PNG frame fits.
constexpr int kMaxMessageBytes = 256 << 20;

// Largest deadline we set [s]: far beyond any real call, safe for chrono.
constexpr double kMaxDeadlineSeconds = 1e8;

/// Options shared by every command.
struct GlobalOptions {
  std::string host{kDefaultHost};
  bool json = false;
  double timeout = kDefaultTimeout;
  bool timeout_given = false;
};

template <typename Request, typename Response>
using UnaryMethod = client::HostClient::Unary<Request, Response>;

/// A usage-level problem found after parsing (bad file, bad "name=value").
struct UsageError {
  std::string message;
};

/// One command line's connection to the daemon plus its output streams.
/// yamorctl reports the daemon's own code (its exit status), so it takes the
/// client's raw statuses rather than its rule.
/// Thread-safety: single-threaded (one per Run call).
class DaemonConnection {
 public:
  // Frames (snapshot, record) can be large PNGs: beyond gRPC's default 4 MB.
  DaemonConnection(const GlobalOptions& options, std::ostream& out, std::ostream& err)
      : options_(options),
        out_(out),
        err_(err),
        host_(options.host, Clamped(options.timeout), {.max_receive_bytes = kMaxMessageBytes}) {}

  std::ostream& out() { return out_; }
  std::ostream& err() { return err_; }
  bool json() const { return options_.json; }
  /// The client of --host.
  client::HostClient& host() { return host_; }
  /// The channel to --host (for services other than yamor.v1.Host).
  const std::shared_ptr<grpc::Channel>& channel() const { return host_.channel(); }

  /// Deadline of a call [s]: --timeout when given, else the default plus
  /// `work_seconds` (the time the call is expected to take).
  double Timeout(double work_seconds = 0.0) const {
    if (options_.timeout_given) return options_.timeout;
    const double work = std::isfinite(work_seconds) ? std::max(0.0, work_seconds) : 0.0;
    return options_.timeout + work;
  }

  /// A deadline of `seconds` as a call takes it (at least 1 ms, at most ~3 years).
  static double Clamped(double seconds) {
    return std::isnan(seconds) ? kMaxDeadlineSeconds : std::clamp(seconds, 1e-3, kMaxDeadlineSeconds);
  }

  /// Sets the deadline of `context` `seconds` from now.
  static void SetDeadline(grpc::ClientContext& context, double seconds) {
    context.set_deadline(client::DeadlineAfter(Clamped(seconds)));
  }

  /// Runs a unary call with a deadline of `timeout` seconds; reports a
  /// failure on stderr and returns the exit status.
  template <typename Request, typename Response>
  int Call(UnaryMethod<Request, Response> method, const Request& request, Response* response,
           double timeout) {
    return Report(host_.TryCall(method, request, response, {.deadline = Clamped(timeout)}));
  }

  /// Prints "yamorctl: CODE: message" for a failed status; returns its code.
  int Report(const grpc::Status& status) {
    if (status.ok()) return 0;
    err_ << "yamorctl: " << StatusCodeName(static_cast<StatusCode>(status.error_code())) << ": "
         << status.error_message() << "\n";
    return static_cast<int>(status.error_code());
  }

  /// Prints `response` as JSON, or as `readable(response)` text.
  template <typename Response, typename Readable>
  void Print(const Response& response, Readable&& readable) {
    if (options_.json) {
      out_ << ToJson(response) << "\n";
    } else {
      out_ << readable(response);
    }
  }

  /// A call whose readable output is `readable(response)`.
  template <typename Request, typename Response, typename Readable>
  int Unary(UnaryMethod<Request, Response> method, const Request& request, double timeout,
            Readable&& readable) {
    Response response;
    if (const int code = Call(method, request, &response, timeout); code != 0) return code;
    Print(response, readable);
    return 0;
  }

  /// A call with no readable output (prints "{}" with --json).
  template <typename Request, typename Response>
  int Unary(UnaryMethod<Request, Response> method, const Request& request, double timeout) {
    return Unary(method, request, timeout, [](const Response&) { return std::string(); });
  }

 private:
  GlobalOptions options_;
  std::ostream& out_;
  std::ostream& err_;
  client::HostClient host_;
};

using Action = std::function<int(DaemonConnection&)>;

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw UsageError{"cannot read " + path};
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw UsageError{"cannot read " + path};
  return text.str();
}

void WriteFile(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
  out.close();
  if (!out) throw UsageError{"cannot write " + path};
}

// ---- get / set ------------------------------------------------------------------

/// A per-module oscillator parameter and its two RPCs.
struct ModuleParameter {
  const char* name;  // DESIGN parameter name, e.g. "amplitude"
  const char* unit;
  const char* help;
  UnaryMethod<v1::ModuleRequest, v1::ValueResponse> get;
  UnaryMethod<v1::SetModuleValueRequest, Empty> set;
};

const std::array<ModuleParameter, 5> kModuleParameters{{
    {"amplitude", "rad", "oscillator amplitude [rad]", &v1::Host::Stub::GetModuleAmplitude,
     &v1::Host::Stub::SetModuleAmplitude},
    {"offset", "rad", "oscillator offset [rad]", &v1::Host::Stub::GetModuleOffset,
     &v1::Host::Stub::SetModuleOffset},
    {"speed", "Hz", "oscillator frequency [Hz]", &v1::Host::Stub::GetModuleSpeed,
     &v1::Host::Stub::SetModuleSpeed},
    {"minangle", "rad", "lower servo set-point limit [rad]", &v1::Host::Stub::GetModuleMinAngle,
     &v1::Host::Stub::SetModuleMinAngle},
    {"maxangle", "rad", "upper servo set-point limit [rad]", &v1::Host::Stub::GetModuleMaxAngle,
     &v1::Host::Stub::SetModuleMaxAngle},
}};

/// A coupling parameter and its two RPCs.
struct CouplingParameter {
  const char* name;  // "phase" or "weight"
  const char* unit;
  const char* help;
  UnaryMethod<v1::CouplingRequest, v1::ValueResponse> get;
  UnaryMethod<v1::SetCouplingValueRequest, Empty> set;
};

const std::array<CouplingParameter, 2> kCouplingParameters{{
    {"phase", "rad", "phase bias of the coupling FROM -> TO [rad]",
     &v1::Host::Stub::GetCouplingPhase, &v1::Host::Stub::SetCouplingPhase},
    {"weight", "", "weight of the coupling FROM -> TO", &v1::Host::Stub::GetCouplingWeight,
     &v1::Host::Stub::SetCouplingWeight},
}};

std::string ValueLine(const std::string& name, double value, const char* unit) {
  return fmt::format("{} = {}{}{}\n", name, value, *unit ? " " : "", unit);
}

void AddGetSet(CLI::App& app, Action& action) {
  CLI::App* get = app.add_subcommand("get", "Read a module or coupling parameter");
  CLI::App* set =
      app.add_subcommand("set", "Change a module or coupling parameter (queued until flush)");
  get->require_subcommand(1);
  set->require_subcommand(1);
  for (const ModuleParameter& p : kModuleParameters) {
    auto id = std::make_shared<uint32_t>();
    auto value = std::make_shared<double>();
    CLI::App* g = get->add_subcommand(p.name, std::string("Get the ") + p.help + " of module ID");
    g->add_option("ID", *id, "Module id")->required();
    g->callback([&action, &p, id] {
      action = [&p, id](DaemonConnection& s) {
        v1::ModuleRequest request;
        request.set_module_id(*id);
        return s.Unary(p.get, request, s.Timeout(), [&](const v1::ValueResponse& r) {
          return ValueLine(fmt::format("{}.{}", p.name, *id), r.value(), p.unit);
        });
      };
    });
    CLI::App* st = set->add_subcommand(p.name, std::string("Set the ") + p.help + " of module ID");
    st->add_option("ID", *id, "Module id")->required();
    st->add_option("VALUE", *value, std::string("New value [") + p.unit + "]")->required();
    st->callback([&action, &p, id, value] {
      action = [&p, id, value](DaemonConnection& s) {
        v1::SetModuleValueRequest request;
        request.set_module_id(*id);
        request.set_value(*value);
        return s.Unary(p.set, request, s.Timeout());
      };
    });
  }
  for (const CouplingParameter& p : kCouplingParameters) {
    auto from = std::make_shared<uint32_t>();
    auto to = std::make_shared<uint32_t>();
    auto value = std::make_shared<double>();
    CLI::App* g = get->add_subcommand(p.name, std::string("Get the ") + p.help);
    g->add_option("FROM", *from, "Module whose equation holds the coupling term")->required();
    g->add_option("TO", *to, "Module whose state drives it")->required();
    g->callback([&action, &p, from, to] {
      action = [&p, from, to](DaemonConnection& s) {
        v1::CouplingRequest request;
        request.set_from_id(*from);
        request.set_to_id(*to);
        return s.Unary(p.get, request, s.Timeout(), [&](const v1::ValueResponse& r) {
          return ValueLine(fmt::format("{}.{}.{}", p.name, *from, *to), r.value(), p.unit);
        });
      };
    });
    CLI::App* st = set->add_subcommand(p.name, std::string("Set the ") + p.help);
    st->add_option("FROM", *from, "Module whose equation holds the coupling term")->required();
    st->add_option("TO", *to, "Module whose state drives it")->required();
    st->add_option("VALUE", *value, "New value")->required();
    st->callback([&action, &p, from, to, value] {
      action = [&p, from, to, value](DaemonConnection& s) {
        v1::SetCouplingValueRequest request;
        request.set_from_id(*from);
        request.set_to_id(*to);
        request.set_value(*value);
        return s.Unary(p.set, request, s.Timeout());
      };
    });
  }
}

// ---- commands without arguments -------------------------------------------------

void AddSimpleCommands(CLI::App& app, Action& action) {
  auto simple = [&](const char* name, const char* help, Action body) {
    app.add_subcommand(name, help)->callback([&action, body] { action = body; });
  };
  const Empty empty;
  simple("time", "Elapsed (virtual) time since the simulation was opened", [empty](DaemonConnection& s) {
    return s.Unary(&v1::Host::Stub::ElapsedTime, empty, s.Timeout(),
                   [](const v1::ElapsedTimeResponse& r) {
                     return fmt::format("{:.3f} s\n", r.seconds());
                   });
  });
  {
    auto simulated = std::make_shared<bool>(false);
    CLI::App* c = app.add_subcommand("position", "Position of the central (tracked) module");
    c->add_flag("--simulated", *simulated,
                "The simulation's own position, whatever the position source (SimulatedPosition)");
    c->callback([&action, simulated, empty] {
      action = [simulated, empty](DaemonConnection& s) {
        return s.Unary(*simulated ? &v1::Host::Stub::SimulatedPosition
                                  : &v1::Host::Stub::RobotPosition,
                       empty, s.Timeout(), FormatPosition);
      };
    });
  }
  simple("sim-enabled", "Whether a simulation is open", [empty](DaemonConnection& s) {
    return s.Unary(&v1::Host::Stub::SimulationModeEnabled, empty, s.Timeout(),
                   [](const v1::SimulationModeEnabledResponse& r) {
                     return std::string(r.enabled() ? "simulation enabled\n"
                                                    : "simulation disabled\n");
                   });
  });
  simple("close", "Close the simulation", [empty](DaemonConnection& s) {
    return s.Unary(&v1::Host::Stub::CloseSimulation, empty, s.Timeout());
  });
  simple("flush", "Send queued parameter changes to the robot", [empty](DaemonConnection& s) {
    return s.Unary(&v1::Host::Stub::Flush, empty, s.Timeout(), [](const v1::FlushResponse& r) {
      return fmt::format("flushed: {} frames sent\n", r.frames_sent());
    });
  });
  simple("refresh", "Resend every parameter (after a reopened link: relink and restore the robot)",
         [empty](DaemonConnection& s) {
           return s.Unary(&v1::Host::Stub::Refresh, empty, s.Timeout(), [](const v1::FlushResponse& r) {
             return fmt::format("refreshed: {} frames sent\n", r.frames_sent());
           });
         });
  simple("modules", "Ids of all modules, in configuration order", [empty](DaemonConnection& s) {
    return s.Unary(&v1::Host::Stub::GetAllModulesId, empty, s.Timeout(),
                   [](const v1::GetAllModulesIdResponse& r) {
                     std::string text;
                     for (uint32_t id : r.module_ids()) {
                       if (!text.empty()) text += ' ';
                       text += std::to_string(id);
                     }
                     return text + "\n";
                   });
  });
  simple("uncouple-all", "Remove every coupling (queued until flush)", [empty](DaemonConnection& s) {
    return s.Unary(&v1::Host::Stub::RemoveAllCoupling, empty, s.Timeout());
  });
  simple("info", "Daemon version, backend, world, workers", [empty](DaemonConnection& s) {
    return s.Unary(&v1::Host::Stub::GetInfo, empty, s.Timeout(), FormatInfo);
  });
  simple("reset", "Restore the simulation to its state when opened (time 0)", [empty](DaemonConnection& s) {
    return s.Unary(&v1::Host::Stub::ResetSimulation, empty, s.Timeout());
  });
  simple("upside-down", "Turn the simulated robot upside down about its centre", [empty](DaemonConnection& s) {
    return s.Unary(&v1::Host::Stub::TurnUpsideDown, empty, s.Timeout());
  });
}

// ---- simulation, connection, control ---------------------------------------------

void AddSimulationCommands(CLI::App& app, Action& action) {
  {
    struct Args {
      std::string world, morphology_file, config_file;
      uint64_t seed = 0;
      double step = 0.0;
    };
    auto a = std::make_shared<Args>();
    CLI::App* c = app.add_subcommand("open", "Open a simulation (replaces the open one)");
    auto* world = c->add_option("--world", a->world, "Built-in world name (default: the daemon's)");
    c->add_option("--morphology", a->morphology_file, "Morphology XML file (instead of --world)")
        ->excludes(world);
    c->add_option("--config", a->config_file,
                  "Robot configuration XML file (default: the world's built-in one)");
    c->add_option("--seed", a->seed, "Seed of the world's random sources");
    c->add_option("--step", a->step, "Physics step [s] (0: default)");
    c->callback([&action, a] {
      action = [a](DaemonConnection& s) {
        v1::OpenSimulationRequest request;
        request.set_world(a->world);
        if (!a->morphology_file.empty()) request.set_morphology_xml(ReadFile(a->morphology_file));
        if (!a->config_file.empty()) request.set_config_xml(ReadFile(a->config_file));
        request.set_seed(a->seed);
        request.set_time_step(a->step);
        return s.Unary(&v1::Host::Stub::OpenSimulation, request, s.Timeout(), FormatOpened);
      };
    });
  }
  {
    struct Args {
      double link_timeout = 0.0;
      bool links_only = false;
    };
    auto a = std::make_shared<Args>();
    CLI::App* c = app.add_subcommand(
        "connect", "Build the robot's bluetooth network, then send the configuration");
    c->add_option("--link-timeout", a->link_timeout,
                  "Wait for each link's acknowledgement [s] (0: daemon default)")
        ->check(CLI::NonNegativeNumber);
    c->add_flag("--links-only", a->links_only, "Only build the links; send no configuration");
    c->callback([&action, a] {
      action = [a](DaemonConnection& s) {
        v1::ConnectRobotRequest request;
        request.set_link_timeout(a->link_timeout);
        request.set_links_only(a->links_only);
        return s.Unary(&v1::Host::Stub::ConnectRobot, request, s.Timeout(a->link_timeout),
                       FormatConnected);
      };
    });
  }
  {
    struct Args {
      std::string uart, cpg, motors;
      std::vector<std::string> targets;
    };
    auto a = std::make_shared<Args>();
    CLI::App* c = app.add_subcommand(
        "control", "Tristate control message (thesis C.2.4); omitted switches stay unchanged");
    const auto on_off = CLI::IsMember({"on", "off"});
    c->add_option("--uart", a->uart, "Sensor board serial line: on|off")->check(on_off);
    c->add_option("--cpg", a->cpg, "Oscillator: on|off")->check(on_off);
    c->add_option("--motors", a->motors, "Servo power: on|off")->check(on_off);
    c->add_option("TARGETS", a->targets, "all, or module ids")->required();
    c->callback([&action, a] {
      action = [a](DaemonConnection& s) {
        auto to_switch = [](const std::string& v) {
          if (v.empty()) return v1::SWITCH_UNCHANGED;
          return v == "on" ? v1::SWITCH_ON : v1::SWITCH_OFF;
        };
        v1::ControlMessageRequest request;
        request.set_uart(to_switch(a->uart));
        request.set_cpg(to_switch(a->cpg));
        request.set_motors(to_switch(a->motors));
        std::pair<bool, std::vector<uint32_t>> targets;
        try {
          targets = ParseModuleTargets(a->targets);
        } catch (const Error& e) {
          throw UsageError{e.what()};
        }
        request.set_all(targets.first);
        for (uint32_t id : targets.second) request.add_module_ids(id);
        return s.Unary(&v1::Host::Stub::SendControlMessage, request, s.Timeout());
      };
    });
  }
  {
    struct Args {
      double seconds = 0.0;
      bool real = false;
    };
    auto a = std::make_shared<Args>();
    CLI::App* c = app.add_subcommand(
        "sleep",
        "Let the robot run: virtual time (as fast as possible) or, with --real, the clock");
    c->add_option("SECONDS", a->seconds, "Duration [s]")->required();
    c->add_flag("--real", a->real, "Wait on the clock even in simulation");
    c->callback([&action, a] {
      action = [a](DaemonConnection& s) {
        v1::SleepRequest request;
        request.set_seconds(a->seconds);
        request.set_real_time(a->real);
        return s.Unary(&v1::Host::Stub::Sleep, request, s.Timeout(a->seconds),
                       [](const v1::SleepResponse& r) {
                         return fmt::format("time {:.3f} s\n", r.time());
                       });
      };
    });
  }
  {
    auto factor = std::make_shared<double>();
    CLI::App* c = app.add_subcommand(
        "freerun", "Step the world in the background at a real-time factor (0: off)");
    c->add_option("FACTOR", *factor, "Simulated seconds per wall-clock second")->required();
    c->callback([&action, factor] {
      action = [factor](DaemonConnection& s) {
        v1::SetFreeRunRequest request;
        request.set_real_time_factor(*factor);
        return s.Unary(&v1::Host::Stub::SetFreeRun, request, s.Timeout());
      };
    });
  }
  {
    struct Args {
      uint32_t from = 0, to = 0;
      double phase = 0.0, weight = 0.0;
    };
    auto a = std::make_shared<Args>();
    CLI::App* c = app.add_subcommand("couple", "Add (or replace) the coupling FROM -> TO");
    c->add_option("FROM", a->from, "Module whose equation holds the coupling term")->required();
    c->add_option("TO", a->to, "Module whose state drives it")->required();
    c->add_option("PHASE", a->phase, "Phase bias [rad]")->required();
    c->add_option("WEIGHT", a->weight, "Weight")->required();
    c->callback([&action, a] {
      action = [a](DaemonConnection& s) {
        v1::AddCouplingRequest request;
        request.set_from_id(a->from);
        request.set_to_id(a->to);
        request.set_phase(a->phase);
        request.set_weight(a->weight);
        return s.Unary(&v1::Host::Stub::AddCoupling, request, s.Timeout());
      };
    });
  }
}

// ---- configuration, morphology, faults, sensors -----------------------------------

const std::map<std::string, v1::ConnectorName> kConnectors{
    {"front", v1::CONNECTOR_FRONT}, {"rear", v1::CONNECTOR_REAR},
    {"left", v1::CONNECTOR_LEFT},   {"right", v1::CONNECTOR_RIGHT},
    {"top", v1::CONNECTOR_TOP},     {"bottom", v1::CONNECTOR_BOTTOM},
};

/// Prints `xml` (readable) or writes it to `file` when one is given.
std::string XmlOut(const std::string& xml, const std::string& file) {
  if (file.empty()) return xml.empty() || xml.back() == '\n' ? xml : xml + "\n";
  WriteFile(file, xml);
  return "";
}

void AddModelCommands(CLI::App& app, Action& action) {
  {
    auto file = std::make_shared<std::string>();
    CLI::App* c = app.add_subcommand("load", "Replace the robot configuration with an XML file");
    c->add_option("FILE", *file, "Robot configuration (thesis schema)")->required();
    c->callback([&action, file] {
      action = [file](DaemonConnection& s) {
        v1::LoadConfigRequest request;
        request.set_config_xml(ReadFile(*file));
        request.set_source_name(*file);
        return s.Unary(&v1::Host::Stub::LoadConfig, request, s.Timeout());
      };
    });
  }
  {
    auto file = std::make_shared<std::string>();
    CLI::App* c = app.add_subcommand("save", "The robot configuration as XML (stdout or FILE)");
    c->add_option("FILE", *file, "Write here instead of stdout");
    c->callback([&action, file] {
      action = [file](DaemonConnection& s) {
        return s.Unary(&v1::Host::Stub::SaveConfig, Empty(), s.Timeout(),
                       [&](const v1::SaveConfigResponse& r) {
                         return XmlOut(r.config_xml(), *file);
                       });
      };
    });
  }
  {
    auto file = std::make_shared<std::string>();
    CLI::App* c = app.add_subcommand(
        "morphology", "The open world's morphology as XML (stdout or FILE)");
    c->add_option("FILE", *file, "Write here instead of stdout");
    c->callback([&action, file] {
      action = [file](DaemonConnection& s) {
        return s.Unary(&v1::Host::Stub::GetMorphology, Empty(), s.Timeout(),
                       [&](const v1::GetMorphologyResponse& r) {
                         return XmlOut(r.morphology_xml(), *file);
                       });
      };
    });
  }
  {
    struct Args {
      uint32_t from = 0, to = 0;
      std::string from_connector, to_connector;
      double angle = 0.0;
    };
    auto a = std::make_shared<Args>();
    CLI::App* c = app.add_subcommand(
        "attach", "Physically attach free module FROM to module TO (thesis C.2.7)");
    std::vector<std::string> names;
    for (const auto& [name, value] : kConnectors) names.push_back(name);
    c->add_option("FROM", a->from, "Module that moves (must be free)")->required();
    c->add_option("FCONN", a->from_connector, "Connector of FROM: front|rear|left|right|top|bottom")
        ->required()
        ->check(CLI::IsMember(names));
    c->add_option("TO", a->to, "Module that stays")->required();
    c->add_option("TCONN", a->to_connector, "Connector of TO")
        ->required()
        ->check(CLI::IsMember(names));
    c->add_option("ANGLE", a->angle, "Connection angle [degrees], multiple of 15")->required();
    c->callback([&action, a] {
      action = [a](DaemonConnection& s) {
        v1::ConnectModulesRequest request;
        request.set_from_id(a->from);
        request.set_from_connector(kConnectors.at(a->from_connector));
        request.set_to_id(a->to);
        request.set_to_connector(kConnectors.at(a->to_connector));
        request.set_angle_degrees(a->angle);
        return s.Unary(&v1::Host::Stub::ConnectModules, request, s.Timeout());
      };
    });
  }
  {
    auto id = std::make_shared<uint32_t>();
    CLI::App* c = app.add_subcommand("detach", "Detach module ID from the robot and put it away");
    c->add_option("ID", *id, "Module id")->required();
    c->callback([&action, id] {
      action = [id](DaemonConnection& s) {
        v1::ModuleRequest request;
        request.set_module_id(*id);
        return s.Unary(&v1::Host::Stub::DisconnectModule, request, s.Timeout());
      };
    });
  }
  {
    auto file = std::make_shared<std::string>();
    CLI::App* c = app.add_subcommand(
        "script", "Run a transformation script (connect, disconnect, pause)");
    c->add_option("FILE", *file, "Script XML")->required();
    c->callback([&action, file] {
      action = [file](DaemonConnection& s) {
        v1::RunTransformationScriptRequest request;
        request.set_script_xml(ReadFile(*file));
        return s.Unary(&v1::Host::Stub::RunTransformationScript, request, s.Timeout(60.0));
      };
    });
  }
  {
    CLI::App* defect = app.add_subcommand("defect", "Break or repair a motor or a module");
    defect->require_subcommand(1);
    struct MotorArgs {
      uint32_t id = 0;
      std::string state;
    };
    auto m = std::make_shared<MotorArgs>();
    CLI::App* motor = defect->add_subcommand(
        "motor", "Motor defect (thesis C.2.6): limp (no torque), stuck (locked) or ok");
    motor->add_option("ID", m->id, "Module id")->required();
    motor->add_option("STATE", m->state, "limp|stuck|ok")
        ->required()
        ->check(CLI::IsMember({"limp", "stuck", "ok"}));
    motor->callback([&action, m] {
      action = [m](DaemonConnection& s) {
        v1::SetMotorDefectRequest request;
        request.set_module_id(m->id);
        request.set_defect(m->state == "limp"    ? v1::MOTOR_LIMP
                           : m->state == "stuck" ? v1::MOTOR_STUCK
                                                 : v1::MOTOR_OK);
        return s.Unary(&v1::Host::Stub::SetMotorDefect, request, s.Timeout());
      };
    });
    auto d = std::make_shared<MotorArgs>();
    CLI::App* module = defect->add_subcommand(
        "module", "Whole-module defect: on (oscillator dead, motor limp) or off (repaired)");
    module->add_option("ID", d->id, "Module id")->required();
    module->add_option("STATE", d->state, "on|off")
        ->required()
        ->check(CLI::IsMember({"on", "off"}));
    module->callback([&action, d] {
      action = [d](DaemonConnection& s) {
        v1::SetModuleDefectRequest request;
        request.set_module_id(d->id);
        request.set_defective(d->state == "on");
        return s.Unary(&v1::Host::Stub::SetModuleDefect, request, s.Timeout());
      };
    });
  }
  {
    struct Args {
      double friction = 0.0, slope = 0.0, direction = 0.0;
      CLI::Option* friction_option = nullptr;
      CLI::Option* slope_option = nullptr;
      CLI::Option* direction_option = nullptr;
    };
    auto a = std::make_shared<Args>();
    CLI::App* c = app.add_subcommand("ground", "Change the ground; omitted values stay");
    a->friction_option =
        c->add_option("--friction", a->friction, "Coulomb friction coefficient (> 0)");
    a->slope_option = c->add_option("--slope", a->slope, "Slope [rad] in [0, pi/2)");
    a->direction_option = c->add_option("--direction", a->direction, "Downhill azimuth [rad]");
    c->callback([&action, a] {
      action = [a](DaemonConnection& s) {
        v1::SetGroundRequest request;
        if (a->friction_option->count()) request.set_friction(a->friction);
        if (a->slope_option->count()) request.set_slope(a->slope);
        if (a->direction_option->count()) request.set_slope_direction(a->direction);
        return s.Unary(&v1::Host::Stub::SetGround, request, s.Timeout());
      };
    });
  }
  {
    auto ids = std::make_shared<std::vector<uint32_t>>();
    CLI::App* c = app.add_subcommand("servos", "Servo angles of modules ID... (all when none)");
    c->add_option("ID", *ids, "Module ids");
    c->callback([&action, ids] {
      action = [ids](DaemonConnection& s) {
        v1::GetServoAnglesRequest request;
        for (uint32_t id : *ids) request.add_module_ids(id);
        return s.Unary(&v1::Host::Stub::GetServoAngles, request, s.Timeout(), FormatServoAngles);
      };
    });
  }
  {
    struct Args {
      uint32_t id = 0, samples = 1;
    };
    auto a = std::make_shared<Args>();
    CLI::App* c =
        app.add_subcommand("accel", "Recent accelerometer samples of module ID (UART on)");
    c->add_option("ID", a->id, "Module id")->required();
    c->add_option("--samples", a->samples, "How many, 1..16 (oldest first)");
    c->callback([&action, a] {
      action = [a](DaemonConnection& s) {
        v1::GetAccelerometerRequest request;
        request.set_module_id(a->id);
        request.set_samples(a->samples);
        return s.Unary(&v1::Host::Stub::GetAccelerometer, request, s.Timeout(),
                       FormatAccelerometer);
      };
    });
  }
  {
    struct Args {
      uint32_t id = 0, samples = 0;
      std::vector<double> reference;
    };
    auto a = std::make_shared<Args>();
    CLI::App* c = app.add_subcommand(
        "orientation", "Orientation of module ID from its accelerometer (UART on): tilt, upside down");
    c->add_option("ID", a->id, "Module id")->required();
    c->add_option("--samples", a->samples, "Latest samples averaged, 1..16 (default 16)");
    c->add_option("--reference", a->reference, "Upright up direction in the module frame: X Y Z")
        ->expected(3);
    c->callback([&action, a] {
      action = [a](DaemonConnection& s) {
        v1::GetOrientationRequest request;
        request.set_module_id(a->id);
        request.set_samples(a->samples);
        if (a->reference.size() == 3) {
          request.mutable_reference_up()->set_x(a->reference[0]);
          request.mutable_reference_up()->set_y(a->reference[1]);
          request.mutable_reference_up()->set_z(a->reference[2]);
        }
        return s.Unary(&v1::Host::Stub::GetOrientation, request, s.Timeout(), FormatOrientation);
      };
    });
  }
}

// ---- evaluate, watch ---------------------------------------------------------------

void AddEvaluate(CLI::App& app, Action& action) {
  struct Args {
    std::string config_file, world, morphology_file;
    std::vector<std::string> params, motor_defects;
    std::vector<uint32_t> module_defects;
    double warmup = 0.0, duration = 0.0, trajectory = 0.0, step = 0.0;
    double friction = 0.0, slope = 0.0, direction = 0.0;
    CLI::Option* friction_option = nullptr;
    CLI::Option* slope_option = nullptr;
    CLI::Option* direction_option = nullptr;
    bool upside_down = false;
    uint64_t seed = 0;
  };
  auto a = std::make_shared<Args>();
  CLI::App* c = app.add_subcommand(
      "evaluate", "Stateless gait evaluation on the daemon's worker pool (velocity, thesis 6.2.1)");
  c->add_option("--config", a->config_file,
                "Robot configuration XML file (default: the world's, else the daemon's)");
  auto* world = c->add_option("--world", a->world, "Built-in world (default: the open one)");
  c->add_option("--morphology", a->morphology_file, "Morphology XML file (instead of --world)")
      ->excludes(world);
  c->add_option("--param", a->params,
                "Parameter override name=value, e.g. amplitude.3=0.5, phase.2.5=1.57");
  c->add_option("--warmup", a->warmup, "Warm-up before measuring [s] (0: 8)");
  c->add_option("--duration", a->duration, "Measured duration [s] (0: 12)");
  c->add_option("--seed", a->seed, "World and oscillator seed");
  c->add_option("--trajectory", a->trajectory, "Sample the trajectory every S seconds (0: no)");
  c->add_option("--step", a->step, "Physics step [s] (0: default)");
  c->add_option("--motor-defect", a->motor_defects,
                "Motor defect of the evaluated robot ID=limp|stuck|ok, e.g. 3=limp (repeatable)");
  c->add_option("--module-defect", a->module_defects,
                "Module of the evaluated robot with a whole-module defect (repeatable)");
  a->friction_option = c->add_option("--friction", a->friction, "Ground friction coefficient (> 0)");
  a->slope_option = c->add_option("--slope", a->slope, "Ground slope [rad] in [0, pi/2)");
  a->direction_option =
      c->add_option("--slope-direction", a->direction, "Downhill azimuth of the slope [rad]");
  c->add_flag("--upside-down", a->upside_down, "Start the robot turned upside down");
  c->callback([&action, a] {
    action = [a](DaemonConnection& s) {
      v1::EvaluateRequest request;
      if (!a->config_file.empty()) request.set_config_xml(ReadFile(a->config_file));
      request.set_world(a->world);
      if (!a->morphology_file.empty()) request.set_morphology_xml(ReadFile(a->morphology_file));
      for (const std::string& text : a->params) {
        std::pair<std::string, double> parameter;
        try {
          parameter = ParseParameterAssignment(text);
        } catch (const Error& e) {
          throw UsageError{e.what()};
        }
        v1::ParameterValue* p = request.add_parameters();
        p->set_name(parameter.first);
        p->set_value(parameter.second);
      }
      request.set_warmup(a->warmup);
      request.set_duration(a->duration);
      request.set_seed(a->seed);
      request.set_trajectory_period(a->trajectory);
      request.set_time_step(a->step);
      for (const std::string& text : a->motor_defects) {
        const std::size_t equals = text.find('=');
        const std::string id_text = text.substr(0, equals);
        const std::string state = equals == std::string::npos ? "" : text.substr(equals + 1);
        char* end = nullptr;
        const unsigned long id = std::strtoul(id_text.c_str(), &end, 10);
        if (id_text.empty() || end != id_text.c_str() + id_text.size() || id > 0xffffffffUL ||
            (state != "limp" && state != "stuck" && state != "ok")) {
          throw UsageError{"--motor-defect \"" + text + "\" is not ID=limp|stuck|ok"};
        }
        v1::SetMotorDefectRequest* d = request.add_motor_defects();
        d->set_module_id(static_cast<uint32_t>(id));
        d->set_defect(state == "limp" ? v1::MOTOR_LIMP : state == "stuck" ? v1::MOTOR_STUCK : v1::MOTOR_OK);
      }
      for (uint32_t id : a->module_defects) {
        v1::SetModuleDefectRequest* d = request.add_module_defects();
        d->set_module_id(id);
        d->set_defective(true);
      }
      if (a->friction_option->count()) request.mutable_ground()->set_friction(a->friction);
      if (a->slope_option->count()) request.mutable_ground()->set_slope(a->slope);
      if (a->direction_option->count()) request.mutable_ground()->set_slope_direction(a->direction);
      request.set_upside_down(a->upside_down);
      const double simulated =
          (a->warmup == 0.0 ? 8.0 : a->warmup) + (a->duration == 0.0 ? 12.0 : a->duration);
      return s.Unary(&v1::Host::Stub::Evaluate, request, s.Timeout(simulated), FormatEvaluation);
    };
  });
}

void AddWatch(CLI::App& app, Action& action, const GlobalOptions& global) {
  struct Args {
    double period = 0.1;
    uint64_t count = 0;
  };
  auto a = std::make_shared<Args>();
  CLI::App* c = app.add_subcommand(
      "watch", "Stream the robot's state (while the world advances: sleep, freerun) and events");
  c->add_option("--period", a->period, "Seconds between updates (virtual time when stepped)");
  c->add_option("--count", a->count, "Stop after N updates (0: until interrupted)");
  c->callback([&action, a, &global] {
    action = [a, &global](DaemonConnection& s) {
      v1::WatchStateRequest request;
      request.set_period(a->period);
      client::CallOptions options;  // no deadline: until interrupted
      if (global.timeout_given || a->count > 0) {
        options.deadline = DaemonConnection::Clamped(s.Timeout(static_cast<double>(a->count) * a->period));
      }
      uint64_t received = 0;
      const grpc::Status status = s.host().TryStream(
          &v1::Host::Stub::WatchState, request,
          [&](const v1::StateUpdate& update) {
            s.Print(update, FormatStateUpdate);
            s.out().flush();
            return !(a->count > 0 && ++received >= a->count);
          },
          options);
      if (a->count > 0 && received >= a->count) return 0;
      const int code = s.Report(status);
      if (status.error_code() == grpc::StatusCode::DEADLINE_EXCEEDED) {
        s.err() << "yamorctl: hint: updates come only while the world advances "
                   "(sleep, freerun)\n";
      }
      return code;
    };
  });
}

// ---- a living robot (yamor-lifelong --listen) ----------------------------------------

void AddLife(CLI::App& app, Action& action, const GlobalOptions& global) {
  struct Args {
    bool watch = false;
    bool replay = false;
  };
  auto a = std::make_shared<Args>();
  CLI::App* c = app.add_subcommand(
      "life", "A running yamor-lifelong's status (--host: its --listen address): state, velocity, "
              "threshold, anomalies, relearning progress, gait; --watch streams its events");
  c->add_flag("--watch", a->watch, "Stream the life's events until it ends (or Ctrl-C)");
  c->add_flag("--replay", a->replay, "With --watch: the events so far first");
  c->callback([&action, a, &global] {
    action = [a, &global](DaemonConnection& s) {
      std::unique_ptr<v1::Lifelong::Stub> stub = v1::Lifelong::NewStub(s.channel());
      if (!a->watch) {
        grpc::ClientContext context;
        DaemonConnection::SetDeadline(context, s.Timeout());
        v1::LifeStatus status;
        if (const int code = s.Report(stub->GetLifeStatus(&context, Empty(), &status)); code != 0) {
          return code;
        }
        s.Print(status, FormatLifeStatus);
        return 0;
      }
      v1::WatchLifeRequest request;
      request.set_replay(a->replay);
      grpc::ClientContext context;
      if (global.timeout_given) DaemonConnection::SetDeadline(context, s.Timeout());
      std::unique_ptr<grpc::ClientReader<v1::LifeUpdate>> reader = stub->WatchLife(&context, request);
      for (v1::LifeUpdate update; reader->Read(&update);) {
        s.Print(update, FormatLifeUpdate);
        s.out().flush();
      }
      return s.Report(reader->Finish());
    };
  });
}

// ---- pictures and videos -------------------------------------------------------------

/// Camera and size options shared by snapshot and record.
struct FrameArgs {
  std::string camera = "follow";
  double distance = 0, elevation = 0, azimuth = 0, camera_height = 0, fov = 0;
  std::vector<double> eye, target;
  uint32_t width = 640, height = 480;
  bool no_labels = false, no_legend = false;
  CLI::Option* distance_option = nullptr;
  CLI::Option* elevation_option = nullptr;
  CLI::Option* azimuth_option = nullptr;
  CLI::Option* camera_height_option = nullptr;
};

void AddFrameOptions(CLI::App* c, FrameArgs& a) {
  c->add_option("--camera", a.camera,
                "follow (the central module), fixed (--eye/--target) or top (ceiling camera)")
      ->check(CLI::IsMember({"follow", "fixed", "top"}))
      ->capture_default_str();
  a.distance_option = c->add_option("--distance", a.distance, "follow: eye to module [m] (0.8)");
  a.elevation_option =
      c->add_option("--elevation", a.elevation, "follow: above the horizon [rad] (0.45)");
  a.azimuth_option =
      c->add_option("--azimuth", a.azimuth, "follow: module-to-eye direction from +x [rad] (-1.2)");
  c->add_option("--eye", a.eye, "fixed: eye X Y Z [m]")->expected(3);
  c->add_option("--target", a.target, "fixed: looked-at point; top: point below, X Y Z [m]")
      ->expected(3);
  a.camera_height_option =
      c->add_option("--camera-height", a.camera_height, "top: height above the target [m] (2.7)");
  c->add_option("--fov", a.fov, "Vertical field of view [rad] (0: 45 deg, top 49.6 deg)");
  c->add_option("--width", a.width, "Image width [px], 1..4096")->capture_default_str();
  c->add_option("--height", a.height, "Image height [px], 1..4096")->capture_default_str();
  c->add_flag("--no-labels", a.no_labels, "No module ids next to the modules");
  c->add_flag("--no-legend", a.no_legend, "No legend strip (colours, ids, time)");
}

v1::Camera ToCamera(const FrameArgs& a) {
  v1::Camera camera;
  camera.set_kind(a.camera == "fixed" ? v1::CAMERA_FIXED
                  : a.camera == "top" ? v1::CAMERA_TOP
                                      : v1::CAMERA_FOLLOW);
  if (a.distance_option->count()) camera.set_distance(a.distance);
  if (a.elevation_option->count()) camera.set_elevation(a.elevation);
  if (a.azimuth_option->count()) camera.set_azimuth(a.azimuth);
  if (a.camera_height_option->count()) camera.set_height(a.camera_height);
  if (a.eye.size() == 3) {
    camera.mutable_eye()->set_x(a.eye[0]);
    camera.mutable_eye()->set_y(a.eye[1]);
    camera.mutable_eye()->set_z(a.eye[2]);
  }
  if (a.target.size() == 3) {
    camera.mutable_target()->set_x(a.target[0]);
    camera.mutable_target()->set_y(a.target[1]);
    camera.mutable_target()->set_z(a.target[2]);
  }
  camera.set_fov(a.fov);
  return camera;
}

void AddSnapshot(CLI::App& app, Action& action) {
  struct Args : FrameArgs {
    std::string file;
  };
  auto a = std::make_shared<Args>();
  CLI::App* c = app.add_subcommand(
      "snapshot", "A picture (PNG) of the simulated robot now, drawn without a display");
  c->add_option("FILE", a->file, "PNG file to write")->required();
  AddFrameOptions(c, *a);
  c->callback([&action, a] {
    action = [a](DaemonConnection& s) {
      v1::RenderFrameRequest request;
      *request.mutable_camera() = ToCamera(*a);
      request.set_width(a->width);
      request.set_height(a->height);
      request.set_hide_labels(a->no_labels);
      request.set_hide_legend(a->no_legend);
      v1::RenderFrameResponse response;
      if (const int code = s.Call(&v1::Host::Stub::RenderFrame, request, &response, s.Timeout(20.0));
          code != 0) {
        return code;
      }
      WriteFile(a->file, response.png());
      v1::RenderFrameResponse shown;
      shown.set_time(response.time());
      s.Print(shown, [&](const v1::RenderFrameResponse& r) {
        return fmt::format("{}: {}x{}, t = {:.3f} s\n", a->file, a->width, a->height, r.time());
      });
      return 0;
    };
  });
}

void AddRecord(CLI::App& app, Action& action) {
  struct Args : FrameArgs {
    std::string file;
    double seconds = 0, fps = 25;
    bool watch = false;
  };
  auto a = std::make_shared<Args>();
  CLI::App* c = app.add_subcommand(
      "record",
      "A video of the simulated robot: frames piped to ffmpeg (a numbered PNG sequence without it)");
  c->add_option("FILE", a->file, "Video file (e.g. walk.mp4)")->required();
  c->add_option("--seconds", a->seconds, "Simulated duration [s]")->required();
  c->add_option("--fps", a->fps, "Frames per simulated second (and of the video)")
      ->capture_default_str();
  c->add_flag("--watch", a->watch,
              "Do not step the world: film it while others advance it (freerun, sleep)");
  AddFrameOptions(c, *a);
  c->callback([&action, a] {
    action = [a](DaemonConnection& s) {
      v1::RecordFramesRequest request;
      *request.mutable_camera() = ToCamera(*a);
      request.set_width(a->width);
      request.set_height(a->height);
      request.set_hide_labels(a->no_labels);
      request.set_hide_legend(a->no_legend);
      request.set_frame_rate(a->fps);
      request.set_seconds(a->seconds);
      request.set_watch(a->watch);
      // Drawing takes tens of milliseconds a frame; watching takes the world's time too.
      const double frames = std::isfinite(a->seconds * a->fps) ? a->seconds * a->fps : 0.0;
      std::unique_ptr<render::VideoWriter> writer;
      int received = 0;
      double first_time = 0, last_time = 0;
      grpc::Status status;
      try {
        status = s.host().TryStream(
            &v1::Host::Stub::RecordFrames, request,
            [&](const v1::VideoFrame& frame) {
              if (!writer) {
                writer = std::make_unique<render::VideoWriter>(
                    a->file, render::VideoOptions{.frame_rate = a->fps});
                first_time = frame.time();
              }
              const std::string& png = frame.png();
              writer->AddFrame({reinterpret_cast<const uint8_t*>(png.data()), png.size()});
              last_time = frame.time();
              ++received;
              return true;
            },
            {.deadline = DaemonConnection::Clamped(s.Timeout(0.2 * frames + (a->watch ? a->seconds : 0.0)))});
      } catch (const Error& e) {
        s.err() << "yamorctl: " << StatusCodeName(e.code()) << ": " << e.what() << "\n";
        return static_cast<int>(e.code());
      }
      if (!status.ok()) {
        const int code = s.Report(status);
        if (status.error_code() == grpc::StatusCode::DEADLINE_EXCEEDED && a->watch) {
          s.err() << "yamorctl: hint: with --watch frames come only while the world advances "
                     "(freerun, sleep)\n";
        }
        if (writer && received > 0) writer->Finish();
        return code;
      }
      if (!writer) {
        s.err() << "yamorctl: the daemon sent no frames\n";
        return kUsageExitCode;
      }
      render::VideoResult result;
      try {
        result = writer->Finish();
      } catch (const Error& e) {
        s.err() << "yamorctl: " << StatusCodeName(e.code()) << ": " << e.what() << "\n";
        return static_cast<int>(e.code());
      }
      if (!result.video) s.err() << "yamorctl: note: " << result.note << "\n";
      v1::VideoFrame shown;
      shown.set_index(static_cast<uint32_t>(received));
      shown.set_time(last_time);
      s.Print(shown, [&](const v1::VideoFrame&) {
        return fmt::format("{}: {} frames, {}x{}, {} fps, t = {:.3f} .. {:.3f} s\n",
                           result.video ? result.path : result.pattern, received, a->width,
                           a->height, a->fps, first_time, last_time);
      });
      return 0;
    };
  });
}

// ---- LED tracking (local: the camera application and files, no daemon) -----------

void AddTracking(CLI::App& app, Action& action, const GlobalOptions& global) {
  {
    auto a = std::make_shared<TrackOptions>();
    auto image = std::make_shared<std::vector<int>>(std::vector<int>{a->width, a->height});
    CLI::App* c = app.add_subcommand(
        "track", "Read the LED tracker's camera (CamApp, yamor-camapp): raw and corrected "
                 "positions, printed or --record FILE.csv (thesis C.2.5)");
    c->add_option("--camapp", a->camapp, "Camera application HOST:PORT")->capture_default_str();
    c->add_option("--calibration", a->calibration,
                  "Calibration file: positions in metres too (without: raw pixels only)");
    c->add_option("--image", *image, "Image width and height without a calibration [px]")
        ->expected(2)
        ->capture_default_str();
    c->add_option("--record", a->record,
                  "Write every sample as CSV (host_time, seq, camera_time_us, seen, pixel_x, "
                  "pixel_y, x, y, connection)");
    c->add_option("--seconds", a->seconds, "Stop after S seconds (0: until interrupted)")
        ->check(CLI::NonNegativeNumber);
    c->add_option("--samples", a->samples, "Stop after N samples (0: no limit)");
    c->callback([&action, &global, a, image] {
      action = [&global, a, image](DaemonConnection& s) {
        TrackOptions options = *a;
        options.width = (*image)[0];
        options.height = (*image)[1];
        options.connect_timeout = global.timeout;  // not connected within --timeout: UNAVAILABLE
        options.json = s.json();
        return Track(options, s.out(), s.err());
      };
    });
  }
  {
    struct Args {
      CalibrateOptions options;
      double led_height = 0.0;
      CLI::Option* led_height_option = nullptr;
    };
    auto a = std::make_shared<Args>();
    CLI::App* c = app.add_subcommand(
        "calibrate", "Fit the camera's homography to pixel <-> metre reference points: the "
                     "reprojection error of each, RMS and max; --output writes the calibration file");
    c->add_option("POINTS_FILE", a->options.points,
                  "A calibration file (docs/camapp.md), or with --lens lines \"x y X Y\" "
                  "(raw pixel, metres)")
        ->required();
    c->add_option("--lens", a->options.lens, "Calibration file whose lens (and LED height) to use");
    c->add_option("--output", a->options.output, "Write the calibration file here");
    a->led_height_option = c->add_option("--led-height", a->led_height, "LED height to write [m]");
    c->callback([&action, a] {
      action = [a](DaemonConnection& s) {
        CalibrateOptions options = a->options;
        if (a->led_height_option->count()) options.led_height = a->led_height;
        options.json = s.json();
        return Calibrate(options, s.out(), s.err());
      };
    });
  }
}

}  // namespace

std::pair<std::string, double> ParseParameterAssignment(std::string_view text) {
  const size_t equals = text.find('=');
  if (equals == std::string_view::npos || equals == 0 || equals + 1 == text.size()) {
    throw Error(StatusCode::kInvalidArgument,
                "parameter \"" + std::string(text) + "\" is not name=value (e.g. amplitude.3=0.5)");
  }
  const std::string name(text.substr(0, equals));
  const std::string value_text(text.substr(equals + 1));
  char* end = nullptr;
  const double value = std::strtod(value_text.c_str(), &end);
  if (end != value_text.c_str() + value_text.size()) {
    throw Error(StatusCode::kInvalidArgument,
                "value \"" + value_text + "\" of parameter " + name + " is not a number");
  }
  return {name, value};
}

std::pair<bool, std::vector<uint32_t>> ParseModuleTargets(const std::vector<std::string>& words) {
  if (words.size() == 1 && words[0] == "all") return {true, {}};
  std::vector<uint32_t> ids;
  for (const std::string& word : words) {
    if (word == "all") {
      throw Error(StatusCode::kInvalidArgument, "\"all\" cannot be combined with module ids");
    }
    size_t used = 0;
    unsigned long id = 0;
    try {
      id = std::stoul(word, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != word.size() || word.empty() || word[0] == '-' || id > 0xffffffffUL) {
      throw Error(StatusCode::kInvalidArgument,
                  "\"" + word + "\" is not a module id or \"all\"");
    }
    ids.push_back(static_cast<uint32_t>(id));
  }
  if (ids.empty()) throw Error(StatusCode::kInvalidArgument, "no modules given (ids or \"all\")");
  return {false, ids};
}

int Run(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  CLI::App app{"yamorctl: drive a yamord robot (gRPC API yamor.v1.Host) from the shell",
               "yamorctl"};
  app.fallthrough();  // global options may follow the command
  app.require_subcommand(0, 1);
  GlobalOptions global;
  app.add_option("--host", global.host, "yamord address HOST:PORT")
      ->envname("YAMORCTL_HOST")
      ->capture_default_str();
  app.add_flag("--json", global.json, "Print the response as one line of JSON");
  CLI::Option* timeout = app.add_option("--timeout", global.timeout, "Deadline of the call [s]")
                             ->check(CLI::Range(1e-3, kMaxDeadlineSeconds))
                             ->capture_default_str();

  Action action;
  AddGetSet(app, action);
  AddSimpleCommands(app, action);
  AddSimulationCommands(app, action);
  AddModelCommands(app, action);
  AddEvaluate(app, action);
  AddWatch(app, action, global);
  AddSnapshot(app, action);
  AddRecord(app, action);
  AddTracking(app, action, global);
  AddLife(app, action, global);
  app.footer(kFooter);  // after the commands, which would inherit it

  try {
    std::vector<std::string> reversed(args.rbegin(), args.rend());  // CLI11 parses from the back
    app.parse(reversed);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e, out, err);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e, out, err);
  } catch (const CLI::ParseError& e) {
    app.exit(e, out, err);
    return kUsageExitCode;
  }
  global.timeout_given = timeout->count() > 0;
  if (!action) {
    err << app.help() << "yamorctl: no command given\n";
    return kUsageExitCode;
  }
  try {
    DaemonConnection session(global, out, err);
    return action(session);
  } catch (const UsageError& e) {
    err << "yamorctl: " << e.message << "\n";
    return kUsageExitCode;
  }
}

}  // namespace yamor::yamorctl
