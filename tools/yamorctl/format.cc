#include "tools/yamorctl/format.h"

#include <fmt/format.h>
#include <google/protobuf/util/json_util.h>

namespace yamor::yamorctl {
namespace {

std::string Vec(const v1::Vector3& v) {
  return fmt::format("({:.4f}, {:.4f}, {:.4f})", v.x(), v.y(), v.z());
}

std::string Quat(const v1::Quaternion& q) {
  return fmt::format("({:.4f}, {:.4f}, {:.4f}, {:.4f})", q.w(), q.x(), q.y(), q.z());
}

std::string Ids(const google::protobuf::RepeatedField<uint32_t>& ids) {
  std::string text;
  for (uint32_t id : ids) {
    if (!text.empty()) text += ' ';
    text += std::to_string(id);
  }
  return text;
}

}  // namespace

std::string ToJson(const google::protobuf::Message& message) {
  google::protobuf::util::JsonPrintOptions options;
  options.always_print_primitive_fields = true;
  options.preserve_proto_field_names = true;
  std::string json;
  // Only unknown Any types can fail, and the API has none.
  const auto status = google::protobuf::util::MessageToJsonString(message, &json, options);
  if (!status.ok()) return "{}";
  return json;
}

std::string FormatPosition(const v1::RobotPositionResponse& r) {
  return fmt::format("position {} m at t={:.3f} s ({})\norientation (w, x, y, z) {}\n",
                     Vec(r.position()), r.time(), r.source(), Quat(r.orientation()));
}

std::string FormatInfo(const v1::GetInfoResponse& r) {
  std::string worlds;
  for (const std::string& w : r.builtin_worlds()) {
    if (!worlds.empty()) worlds += ' ';
    worlds += w;
  }
  const std::string free_run =
      r.free_run_factor() > 0.0 ? fmt::format("{}x real time", r.free_run_factor()) : "off";
  return fmt::format(
      "version           {}\n"
      "backend           {}\n"
      "world             {}\n"
      "connected         {}\n"
      "master node       {}\n"
      "free run          {}\n"
      "evaluate workers  {}\n"
      "max calls         {}\n"
      "built-in worlds   {}\n",
      r.version(), r.backend(), r.world(), r.connected() ? "yes" : "no", r.master_node(),
      free_run, r.worker_capacity(), r.max_concurrent_calls(), worlds);
}

std::string FormatOpened(const v1::OpenSimulationResponse& r) {
  return fmt::format("opened: modules {}, central module {}\n", Ids(r.module_ids()),
                     r.central_module());
}

std::string FormatConnected(const v1::ConnectRobotResponse& r) {
  return fmt::format("connected: {} links in {:.3f} s, {} frames sent\n", r.links(), r.elapsed(),
                     r.frames_sent());
}

std::string FormatServoAngles(const v1::GetServoAnglesResponse& r) {
  std::string text;
  for (const v1::ServoAngle& a : r.angles()) {
    text += fmt::format("{:>3}  {:+.6f} rad\n", a.module_id(), a.angle());
  }
  return text;
}

std::string FormatAccelerometer(const v1::GetAccelerometerResponse& r) {
  std::string text;
  for (const v1::AccelerometerSample& s : r.samples()) {
    text += fmt::format("counts ({:>4}, {:>4}, {:>4})  acceleration {} m/s^2\n", s.x(), s.y(),
                        s.z(), Vec(s.acceleration()));
  }
  return text;
}

std::string FormatOrientation(const v1::GetOrientationResponse& r) {
  constexpr double kDegrees = 180.0 / 3.14159265358979323846;
  if (!r.valid()) {
    return fmt::format("not valid: accelerating (|mean| {:.2f} m/s^2 over {} samples)\n",
                       r.magnitude(), r.samples());
  }
  return fmt::format(
      "up           {}\n"
      "tilt         {:.1f} deg\n"
      "upside down  {}\n"
      "|mean|       {:.2f} m/s^2, largest deviation {:.2f} m/s^2 over {} samples\n",
      Vec(r.up()), r.tilt() * kDegrees, r.upside_down() ? "yes" : "no", r.magnitude(),
      r.max_deviation(), r.samples());
}

std::string FormatEvaluation(const v1::EvaluateResponse& r) {
  std::string text;
  if (r.diverged()) text += fmt::format("diverged: {}\n", r.divergence());
  text += fmt::format(
      "velocity  {:.6f} m/s ({:.2f} cm/s)\n"
      "distance  {:.6f} m\n"
      "final     {} m\n"
      "wall      {:.3f} s\n",
      r.velocity(), 100.0 * r.velocity(), r.distance(), Vec(r.final_pose().position()),
      r.wall_seconds());
  if (r.trajectory_size() > 0) {
    text += "trajectory (t [s]  x y z [m]):\n";
    for (const v1::TrajectorySample& t : r.trajectory()) {
      text += fmt::format("{:9.3f}  {:+.4f} {:+.4f} {:+.4f}\n", t.time(), t.position().x(),
                          t.position().y(), t.position().z());
    }
  }
  return text;
}

std::string FormatStateUpdate(const v1::StateUpdate& u) {
  std::string text = fmt::format("t={:.3f} s  position {} m  velocity {} m/s\n", u.time(),
                                 Vec(u.central().position()), Vec(u.velocity()));
  for (const v1::StateEvent& e : u.events()) {
    text += fmt::format("  event {} module {}: {}\n", e.kind(), e.module_id(), e.detail());
  }
  return text;
}

std::string FormatLifeStatus(const v1::LifeStatus& s) {
  std::string text = fmt::format(
      "{} at t={:.1f} s{}  velocity {:.2f} cm/s  ema {:.2f} cm/s  threshold {:.2f} cm/s  gait {}\n"
      "anomalies {} (recalled {}, relearned {})  trials {}  daemon gaps {}\n",
      s.state(), s.time(), s.ended() ? " (ended)" : "", s.velocity() * 100, s.ema() * 100,
      s.threshold() * 100, s.gait(), s.anomalies(), s.recalls(), s.relearns(), s.trials(), s.gaps());
  if (s.state() == "relearning") {
    text += fmt::format("relearning ({}): trial {} of {}\n", s.mode(), s.relearn_trials(),
                        s.relearn_budget());
  }
  if (!s.detail().empty()) text += "now: " + s.detail() + "\n";
  if (!s.robot().empty()) text += "robot: " + s.robot() + "\n";
  return text;
}

std::string FormatLifeUpdate(const v1::LifeUpdate& u) {
  return fmt::format("t={:.1f} s  {:<22} [{}] {}\n", u.time(), u.kind(), u.status().state(), u.json());
}

}  // namespace yamor::yamorctl
