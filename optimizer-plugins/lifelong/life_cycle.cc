#include "optimizer-plugins/lifelong/life_cycle.h"

#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>
#include <utility>

#include "common/format.h"
#include "common/log.h"
#include "common/status.h"
#include "cpg/config_xml.h"
#include "cpg/symmetry.h"

namespace yamor::lifelong {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double UnixNow() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

bool IsVelocityTrigger(const std::string& trigger) {
  return trigger == "velocity_drop" || trigger == "velocity_increase";
}

// "friction 0.2, slope 0 rad towards 0 rad" (the driver's ground_changed detail).
void ParseGround(const std::string& detail, std::optional<double>& friction, std::optional<double>& slope,
                 std::optional<double>& direction) {
  std::istringstream in(detail);
  std::string word;
  double f = 0, s = 0, d = 0;
  std::string comma, rad, towards;
  if (in >> word && word == "friction" && in >> f) {
    friction = f;
    in >> comma;  // "," is glued to the number or separate
    if (in >> word && word == "slope" && in >> s) {
      slope = s;
      if (in >> rad >> towards && towards == "towards" && in >> d) direction = d;
    }
  }
}

std::string JsonInt(long long v) { return std::to_string(v); }
std::string JsonBool(bool v) { return v ? "true" : "false"; }

std::string JsonStrings(const std::vector<std::string>& items) {
  std::string out = "[";
  for (std::size_t i = 0; i < items.size(); ++i) {
    if (i) out += ',';
    out += JsonString(items[i]);
  }
  return out + "]";
}

}  // namespace

std::string JsonString(const std::string& text) {
  std::string out = "\"";
  for (unsigned char c : text) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\r': out += "\\r"; break;
      case '\t': out += "\\t"; break;
      default:
        if (c < 0x20) {
          char buffer[8];
          std::snprintf(buffer, sizeof buffer, "\\u%04x", c);
          out += buffer;
        } else {
          out += static_cast<char>(c);
        }
    }
  }
  return out + "\"";
}

std::string JsonNumber(double value) { return std::isfinite(value) ? FormatDouble(value) : "null"; }

LifeCycle::LifeCycle(RobotPort& port, Relearner& relearner, GaitDatabase& db, LifeLog& log, LifeOptions options)
    : port_(port), relearner_(relearner), db_(db), log_(log), options_(std::move(options)),
      monitor_(options_.anomaly) {
  auto positive = [](double v, const char* what) {
    if (!(std::isfinite(v) && v > 0)) {
      throw Error(StatusCode::kInvalidArgument, std::string(what) + " " + FormatRounded(v) + " must be > 0");
    }
  };
  auto non_negative = [](double v, const char* what) {
    if (!(std::isfinite(v) && v >= 0)) {
      throw Error(StatusCode::kInvalidArgument, std::string(what) + " " + FormatRounded(v) + " must be >= 0");
    }
  };
  positive(options_.window_periods, "window periods");
  positive(options_.trial_periods, "trial periods");
  non_negative(options_.settle_periods, "settle periods");
  non_negative(options_.quiet_periods, "quiet periods");
  non_negative(options_.recall_accept, "recall acceptance");
  non_negative(options_.recall_noise_factor, "recall noise factor");
  non_negative(options_.recall_fail_factor, "recall fail factor");
  if (!(options_.recall_restart_floor >= 0 && options_.recall_restart_floor <= 1)) {
    throw Error(StatusCode::kInvalidArgument,
                "recall restart floor " + FormatRounded(options_.recall_restart_floor) + " is outside [0, 1]");
  }
  if (!(options_.recall_floor >= 0 && options_.recall_floor <= 1)) {
    throw Error(StatusCode::kInvalidArgument,
                "recall floor " + FormatRounded(options_.recall_floor) + " is outside [0, 1]");
  }
  if (options_.recall_max_windows < 1 || options_.recall_max_windows > 100) {
    throw Error(StatusCode::kInvalidArgument, "recall windows " + std::to_string(options_.recall_max_windows) +
                                                  " is outside [1, 100]");
  }
  if (options_.noise_write_windows < 0) {
    throw Error(StatusCode::kInvalidArgument,
                "noise write interval " + std::to_string(options_.noise_write_windows) + " must be >= 0 windows");
  }
  non_negative(options_.max_life_seconds, "life time limit");
  if (!(options_.orientation_cos > 0 && options_.orientation_cos < 1)) {
    throw Error(StatusCode::kInvalidArgument,
                "orientation cosine " + FormatRounded(options_.orientation_cos) + " is outside (0, 1)");
  }
  if (options_.orientation_learn_windows < 0 || options_.orientation_confirmations < 1) {
    throw Error(StatusCode::kInvalidArgument,
                "orientation learning windows must be >= 0 and confirmations >= 1");
  }
  if (options_.max_recall < 0 || options_.max_anomalies < 0) {
    throw Error(StatusCode::kInvalidArgument, "recall and anomaly limits must be >= 0");
  }
  if (options_.adaptation.max_free < 1) {
    throw Error(StatusCode::kInvalidArgument,
                "free parameter budget " + std::to_string(options_.adaptation.max_free) + " must be >= 1");
  }
}

void LifeCycle::RequestStop() {
  stop_.store(true);
  port_.RequestStop();
  relearner_.RequestStop();
}

LifeStatus LifeCycle::Status() const {
  std::lock_guard lock(mu_);
  return status_;
}

void LifeCycle::SetState(const std::string& state, const std::string& detail) {
  std::lock_guard lock(mu_);
  status_.state = state;
  status_.detail = detail;
  status_.time = LifeTime(last_robot_time_);
  status_.ema = monitor_.ema();
  status_.threshold = monitor_.initialised() ? monitor_.Threshold() : 0.0;
  status_.gait = current_.id;
  if (state != "relearning") status_.relearn_trials = 0;
}

void LifeCycle::Row(double robot_time, double velocity, const std::string& event) {
  TimelineRow row;
  row.time = LifeTime(robot_time);
  row.velocity = velocity;
  row.ema = monitor_.initialised() ? monitor_.ema() : kNaN;
  {
    std::lock_guard lock(mu_);
    row.state = status_.state;
    status_.time = row.time;
    if (std::isfinite(velocity)) status_.velocity = velocity;
    status_.ema = monitor_.ema();
    status_.threshold = monitor_.initialised() ? monitor_.Threshold() : 0.0;
  }
  row.event = event;
  row.gait = current_.id;
  log_.Row(row);
}

void LifeCycle::Event(double robot_time, const std::string& kind,
                      std::vector<std::pair<std::string, std::string>> fields) {
  log_.Event(LifeEvent{.time = LifeTime(robot_time), .kind = kind, .fields = std::move(fields)});
}

bool LifeCycle::LimitReached(std::string* reason) const {
  if (options_.max_life_seconds > 0 && LifeTime(last_robot_time_) >= options_.max_life_seconds) {
    *reason = "time limit";
    return true;
  }
  std::lock_guard lock(mu_);
  if (options_.max_anomalies > 0 && status_.anomalies >= options_.max_anomalies && !pending_ && !next_) {
    *reason = "anomaly limit";
    return true;
  }
  return false;
}

LifeSummary LifeCycle::Run(const InitialGait& initial) {
  Start(initial);
  std::string reason;
  while (true) {
    if (Stopping()) {
      reason = "stopped";
      break;
    }
    if (LimitReached(&reason)) break;
    try {
      try {
        if (pending_) {
          Adapt(*pending_, /*resumed=*/true);
        } else if (next_) {
          const Anomaly anomaly = *next_;
          next_.reset();
          Adapt(anomaly, /*resumed=*/false);
        } else {
          Step();
        }
      } catch (const Error& e) {
        if (e.code() != StatusCode::kUnavailable || Stopping()) throw;
        HandleLoss(e.what());
      }
    } catch (const Error& e) {
      if (Stopping() && e.code() == StatusCode::kCancelled) {
        reason = "stopped";
        break;
      }
      throw;
    }
  }
  StoreNoise();
  SetState("stopped", reason);
  Event(last_robot_time_, "end", {{"reason", JsonString(reason)}});
  return LifeSummary{reason, Status()};
}

void LifeCycle::Start(const InitialGait& initial) {
  SetState("starting");
  const cpg::RobotConfig config = cpg::ParseConfigXml(initial.config_xml, initial.source);
  const std::string canonical = cpg::WriteConfigXml(config);
  port_.Walk(canonical);
  // From rest the robot needs a while to reach its gait: one window more
  // than after a gait change, so the first window does not set a low
  // expectation.
  port_.Settle(options_.settle_periods + options_.window_periods);
  // What the daemon reported before this life (its setup, a previous
  // client's changes) is history, not news.
  port_.TakeEvents();
  auto [body, morphology_xml] = port_.Body();
  std::vector<int> ids;
  for (const auto& m : body.modules()) ids.push_back(m.id);
  for (const auto& [id, driven] : cpg::ActivityFromConfig(config, ids)) {
    if (driven) driven_.insert(id);
  }
  const std::string key = cpg::MorphologyKey(WithKnownActivity(body, driven_, dead_));
  last_robot_time_ = port_.Now();
  const AccelReading accel = port_.ReadAccelerometer();
  double norm = 0;
  for (double a : accel.mean) norm += a * a;
  norm = std::sqrt(norm);
  if (accel.valid && norm > 1.0) {
    std::array<double, 3> up{};
    for (int i = 0; i < 3; ++i) up[i] = accel.mean[i] / norm * (options_.starts_upside_down ? -1 : 1);
    up_ = up;
    last_accel_ = accel;
  } else {
    Log().warn("lifelong: no accelerometer reference ({}); orientation is not watched",
               accel.error.empty() ? "no gravity seen" : accel.error);
    Event(last_robot_time_, "no_orientation",
          {{"error", JsonString(accel.error.empty() ? "no gravity seen" : accel.error)}});
  }
  orientation_ = options_.starts_upside_down ? Orientation::kUpsideDown : Orientation::kUpright;

  std::optional<GaitRecord> record = db_.FindSame(key, orientation_, canonical);
  bool known = record.has_value();
  if (!record) {
    GaitRecord r;
    r.morphology_key = key;
    r.orientation = orientation_;
    r.config_xml = canonical;
    r.problem_xml = initial.problem_xml;
    r.origin = "initial";
    r.symptoms.trigger = "initial";
    r.id = db_.Insert(r);
    record = r;
  }
  current_ = Gait{.id = record->id,
                  .config_xml = canonical,
                  .problem_xml = initial.problem_xml.empty() ? record->problem_xml : initial.problem_xml,
                  .key = key,
                  .orientation = orientation_,
                  .expected = record->expected_velocity};
  first_window_ = FirstWindow::kRecordUse;
  monitor_.Reset();
  NewGait();
  Event(last_robot_time_, "start",
        {{"gait", JsonInt(current_.id)},
         {"known", JsonBool(known)},
         {"source", JsonString(initial.source)},
         {"morphology_key", JsonString(key)},
         {"orientation", JsonString(OrientationName(orientation_))},
         {"mode", JsonString(relearner_.mode())}});
  SetState("walking");
}

void LifeCycle::Step() {
  if (auto anomaly = TakeEvents()) {
    Adapt(*anomaly, false);
    return;
  }
  const Window w = port_.Measure(options_.window_periods);
  last_robot_time_ = w.end_time;
  const AccelReading accel = port_.ReadAccelerometer();
  if (accel.valid) last_accel_ = accel;
  const Observation o = monitor_.Observe(w.velocity);
  const bool plain = o.verdict == Verdict::kNormal || o.verdict == Verdict::kInitialised ||
                     o.verdict == Verdict::kLearning;
  Row(w.end_time, w.velocity, plain ? "" : VerdictName(o.verdict));
  if (o.verdict == Verdict::kInitialised && first_window_ != FirstWindow::kNothing) {
    if (first_window_ == FirstWindow::kRecordUse) {
      db_.RecordUse(current_.id, UnixNow(), w.velocity, std::nullopt, UseOutcome::kAccepted);
    } else {
      db_.SetExpectedVelocity(current_.id, w.velocity);
    }
    current_.expected = w.velocity;
    first_window_ = FirstWindow::kNothing;
  }
  // The gait's window noise d and the EMA v it is measured around, from
  // in-band windows only (an out-of-band one enters d at the band's edge,
  // and a drop's windows are the new ground's, not the gait's). v becomes
  // the gait's expected velocity: a recall trial is judged against v ± d,
  // not against the one window that first set the expectation (an erratic
  // gait's first window is off by about d itself). Written once learned,
  // then every noise_write_windows windows and when the gait is left: each
  // write is one transaction, so a kill -9 loses at most the last few
  // windows' refinement, never the estimate of a gait that walked for hours
  // (a write only at the anomaly would lose it all).
  if ((o.verdict == Verdict::kNormal || o.verdict == Verdict::kLearning) && monitor_.noise_learned()) {
    noise_.gait = current_.id;
    noise_.noise = monitor_.noise();
    noise_.ema = monitor_.ema();
    noise_.windows = monitor_.windows();
    noise_.valid = true;
    if (options_.noise_write_windows > 0 &&
        (noise_.written_windows < 0 || noise_.windows - noise_.written_windows >= options_.noise_write_windows)) {
      StoreNoise();
    }
  }
  if (auto anomaly = TakeEvents()) {
    anomaly->velocity_after = w.velocity;
    Adapt(*anomaly, false);
    return;
  }
  // Orientation: a gait whose own motion turns the central module (a rolling
  // wheel) is not watched; otherwise a flip counts at once when the velocity
  // also fell, else after orientation_confirmations windows.
  const std::optional<Orientation> orientation = Classify(accel);
  bool flipped = false;
  if (orientation_watched_) {
    const bool off = !orientation || *orientation != current_.orientation;
    if (orientation_seen_ < options_.orientation_learn_windows) {
      ++orientation_seen_;
      if (off) {
        orientation_watched_ = false;
        Event(w.end_time, "orientation_not_watched",
              {{"gait", JsonInt(current_.id)},
               {"reason", JsonString("the gait's own motion turns the central module")}});
      }
    } else if (orientation && *orientation != current_.orientation) {
      ++orientation_flips_;
      flipped = true;
    } else {
      orientation_flips_ = 0;
    }
  }
  if (flipped && (IsAnomaly(o.verdict) || orientation_flips_ >= options_.orientation_confirmations)) {
    Adapt(Anomaly{.trigger = "orientation",
                  .time = w.end_time,
                  .velocity_before = o.before,
                  .velocity_after = w.velocity,
                  .detail = OrientationName(*orientation)},
          false);
    return;
  }
  if (o.verdict == Verdict::kIncrease) {
    Event(w.end_time, "velocity_increase",
          {{"before", JsonNumber(o.before)}, {"measured", JsonNumber(w.velocity)}});
  }
  if (IsAnomaly(o.verdict)) {
    Adapt(Anomaly{.trigger = o.verdict == Verdict::kDrop ? "velocity_drop" : "velocity_increase",
                  .time = w.end_time,
                  .velocity_before = o.before,
                  .velocity_after = w.velocity},
          false);
  }
}

std::optional<LifeCycle::Anomaly> LifeCycle::TakeEvents() {
  std::optional<Anomaly> first;
  for (const RobotEvent& e : port_.TakeEvents()) {
    Note(e);
    // Our own configuration changes are not news.
    if (e.kind == "config_loaded" || e.kind == "connected") continue;
    std::vector<std::pair<std::string, std::string>> fields = {{"event", JsonString(e.kind)}};
    if (e.module_id >= 0) fields.emplace_back("module", JsonInt(e.module_id));
    if (!e.detail.empty()) fields.emplace_back("detail", JsonString(e.detail));
    Event(e.time, "robot_event", fields);
    const Observation o = monitor_.OnEvent(e.kind);
    if (o.verdict == Verdict::kPhysicalChange && !first) {
      // Detected now (after the window it came in), reported at e.time.
      first = Anomaly{.trigger = e.kind,
                      .time = std::max(e.time, last_robot_time_),
                      .velocity_before = monitor_.ema(),
                      .velocity_after = 0,
                      .module_id = e.module_id,
                      .detail = e.detail,
                      .event_time = e.time};
    }
  }
  return first;
}

void LifeCycle::Note(const RobotEvent& e) {
  if (e.kind == "defect_set" || e.kind == "defect_cleared") {
    const bool set = e.kind == "defect_set";
    if (e.detail.rfind("module", 0) == 0) {
      if (set) {
        dead_.insert(e.module_id);
      } else {
        dead_.erase(e.module_id);
      }
    } else if (e.detail.rfind("motor", 0) == 0) {
      if (set) {
        motor_defects_[e.module_id] = e.detail.find("stuck") != std::string::npos ? "stuck" : "limp";
      } else {
        motor_defects_.erase(e.module_id);
      }
    }
  } else if (e.kind == "module_connected" && options_.drive_new_modules && e.module_id >= 0) {
    const cpg::RobotConfig config = cpg::ParseConfigXml(current_.config_xml, "the current gait");
    if (config.FindModule(e.module_id) == nullptr && !driven_.count(e.module_id)) {
      driven_.insert(e.module_id);  // a new module brings its own oscillator
    }
  } else if (e.kind == "ground_changed") {
    ParseGround(e.detail, friction_, slope_, slope_direction_);
  }
}

std::vector<std::string> LifeCycle::Defects() const {
  std::vector<std::string> out;
  for (const auto& [id, kind] : motor_defects_) out.push_back("motor " + std::to_string(id) + " " + kind);
  for (int id : dead_) out.push_back("module " + std::to_string(id));
  std::sort(out.begin(), out.end());
  return out;
}

std::optional<Orientation> LifeCycle::Classify(const AccelReading& reading) const {
  if (!reading.valid || !up_) return std::nullopt;
  double norm = 0, dot = 0;
  for (int i = 0; i < 3; ++i) {
    norm += reading.mean[i] * reading.mean[i];
    dot += reading.mean[i] * (*up_)[i];
  }
  norm = std::sqrt(norm);
  if (norm < 1.0) return std::nullopt;  // falling, or no gravity seen
  const double c = dot / norm;
  if (c >= options_.orientation_cos) return Orientation::kUpright;
  if (c <= -options_.orientation_cos) return Orientation::kUpsideDown;
  return std::nullopt;
}

std::pair<cpg::ModuleGraph, std::string> LifeCycle::CurrentBody(std::string* key) {
  auto [body, xml] = port_.Body();
  cpg::ModuleGraph graph = WithKnownActivity(body, driven_, dead_);
  *key = cpg::MorphologyKey(graph);
  return {std::move(graph), std::move(xml)};
}

void LifeCycle::Adapt(Anomaly anomaly, bool resumed) {
  pending_ = anomaly;
  StoreNoise();  // the gait is left: what it learned of its noise is kept
  if (!resumed) {
    std::lock_guard lock(mu_);
    ++status_.anomalies;
  }
  SetState("anomaly", anomaly.trigger);
  if (!resumed) {
    std::vector<std::pair<std::string, std::string>> fields = {
        {"trigger", JsonString(anomaly.trigger)},
        {"velocity_before", JsonNumber(anomaly.velocity_before)},
        {"velocity_after", JsonNumber(anomaly.velocity_after)},
        {"gait", JsonInt(current_.id)}};
    if (anomaly.module_id >= 0) fields.emplace_back("module", JsonInt(anomaly.module_id));
    if (anomaly.event_time >= 0) fields.emplace_back("event_time", JsonNumber(LifeTime(anomaly.event_time)));
    if (!anomaly.detail.empty()) fields.emplace_back("detail", JsonString(anomaly.detail));
    Event(anomaly.time, "anomaly", fields);
    Row(anomaly.time, kNaN, "anomaly: " + anomaly.trigger);
  }
  // A physical change may be one step of several (a transformation script):
  // wait until the body stops changing.
  if (!IsVelocityTrigger(anomaly.trigger) && anomaly.trigger != "orientation") {
    for (int i = 0; i < 10; ++i) {
      port_.Settle(options_.quiet_periods);
      if (!TakeEvents()) break;
    }
  }
  std::string key;
  auto [graph, morphology_xml] = CurrentBody(&key);
  const AccelReading accel = port_.ReadAccelerometer();
  if (accel.valid) last_accel_ = accel;
  if (orientation_watched_ || anomaly.trigger == "orientation") {
    orientation_ = Classify(accel).value_or(orientation_);
  }
  last_robot_time_ = port_.Now();
  const bool body_changed = key != current_.key;
  Symptoms symptoms;
  symptoms.trigger = anomaly.trigger;
  symptoms.velocity_before = anomaly.velocity_before;
  symptoms.velocity_after = anomaly.velocity_after;
  if (last_accel_.valid) {
    symptoms.has_acceleration = true;
    symptoms.acceleration = last_accel_.mean;
    symptoms.acceleration_spread = last_accel_.spread;
  }
  symptoms.defects = Defects();
  Event(last_robot_time_, "assessed",
        {{"morphology_key", JsonString(key)},
         {"body_changed", JsonBool(body_changed)},
         {"orientation", JsonString(OrientationName(orientation_))},
         {"defects", JsonStrings(symptoms.defects)}});
  if (!Recall(anomaly, key, orientation_, symptoms)) {
    Relearn(anomaly, graph, key, orientation_, symptoms, body_changed, morphology_xml);
  }
  pending_.reset();
  SetState("walking");
}

bool LifeCycle::Recall(const Anomaly& anomaly, const std::string& key, Orientation orientation,
                       const Symptoms& symptoms) {
  (void)anomaly;
  SetState("recalling");
  const std::vector<RankedGait> ranked = db_.Match({.morphology_key = key,
                                                    .orientation = orientation,
                                                    .symptoms = symptoms,
                                                    .current = current_.id,
                                                    .limit = options_.max_recall});
  std::vector<std::string> ids;
  for (const RankedGait& r : ranked) ids.push_back(std::to_string(r.gait.id));
  Event(last_robot_time_, "recall", {{"candidates", JsonStrings(ids)}});
  for (const RankedGait& r : ranked) {
    if (Stopping()) throw Error(StatusCode::kCancelled, "stopped while recalling");
    SetState("recalling", "gait " + std::to_string(r.gait.id));
    port_.Walk(r.gait.config_xml);
    port_.Settle(options_.settle_periods);
    // One window, or for a noisy gait whose first windows are inconclusive a
    // few more (each one a trial), judged on the mean of the windows so far;
    // a clean gait's low first window may get a second (JudgeTrial).
    double sum = 0, mean = 0;
    int n = 0;
    TrialVerdict verdict;
    while (true) {
      if (n > 0 && Stopping()) throw Error(StatusCode::kCancelled, "stopped while recalling");
      const Window w = port_.Measure(options_.trial_periods);
      last_robot_time_ = w.end_time;
      ++n;
      sum += w.velocity;
      mean = sum / n;
      {
        std::lock_guard lock(mu_);
        ++status_.trials;
        if (n > 1) status_.detail = "gait " + std::to_string(r.gait.id) + " window " + std::to_string(n);
      }
      verdict = JudgeTrial(r.gait, mean, w.velocity, n);
      const char* decision = verdict.accepted ? "accepted" : verdict.longer ? "longer" : "rejected";
      Row(w.end_time, w.velocity,
          "recall gait " + std::to_string(r.gait.id) + (n > 1 ? " window " + std::to_string(n) : "") + " " + decision);
      Event(w.end_time, "recall_trial",
            {{"gait", JsonInt(r.gait.id)},
             {"likelihood", JsonNumber(r.likelihood)},
             {"reasons", JsonString(r.reasons)},
             {"velocity", JsonNumber(w.velocity)},
             {"window", JsonInt(n)},
             {"mean", JsonNumber(mean)},
             {"judged", JsonNumber(verdict.velocity)},
             {"expected", JsonNumber(r.gait.expected_velocity)},
             {"noise", JsonNumber(r.gait.velocity_noise)},
             {"accept_level", JsonNumber(verdict.accept_level)},
             {"fail_level", JsonNumber(verdict.fail_level)},
             {"decision", JsonString(decision)},
             {"accepted", JsonBool(verdict.accepted)}});
      if (!verdict.longer) break;
    }
    const bool accepted = verdict.accepted;
    const double judged = verdict.velocity;
    db_.RecordUse(r.gait.id, UnixNow(), judged, current_.id, accepted ? UseOutcome::kAccepted : UseOutcome::kRejected);
    if (accepted) {
      const std::int64_t previous = current_.id;
      current_ = Gait{.id = r.gait.id,
                      .config_xml = r.gait.config_xml,
                      .problem_xml = r.gait.problem_xml,
                      .key = key,
                      .orientation = orientation,
                      .expected = judged};
      monitor_.Seed(judged);
      NewGait();
      {
        std::lock_guard lock(mu_);
        ++status_.recalls;
      }
      Event(last_robot_time_, "recalled",
            {{"gait", JsonInt(current_.id)},
             {"previous", JsonInt(previous)},
             {"velocity", JsonNumber(judged)},
             {"windows", JsonInt(n)}});
      return true;
    }
  }
  return false;
}

void LifeCycle::Relearn(const Anomaly& anomaly, const cpg::ModuleGraph& graph, const std::string& key,
                        Orientation orientation, const Symptoms& symptoms, bool body_changed,
                        const std::string& morphology_xml) {
  (void)anomaly;
  SetState("relearning");
  const int n = ++relearn_count_;
  {
    std::lock_guard lock(mu_);
    ++status_.relearns;
  }
  AdaptationOptions adaptation = options_.adaptation;
  // One seed drives a life: the n-th relearning's budget rule and its
  // optimizer both draw from seed + n - 1 (options_.adaptation.seed is not used).
  adaptation.seed = options_.seed + static_cast<std::uint64_t>(n) - 1;
  const AdaptationPlan plan =
      PlanAdaptation(graph, current_.config_xml, current_.problem_xml, body_changed, adaptation);
  Event(last_robot_time_, "relearn",
        {{"run", JsonInt(n)},
         {"how", JsonString(plan.how)},
         {"mode", JsonString(relearner_.mode())},
         {"free", JsonStrings(plan.free)},
         {"explanation", JsonString(plan.explanation)}});
  port_.Walk(plan.start_config_xml);
  port_.Settle(options_.settle_periods);

  RelearnRequest request;
  request.problem_xml = plan.problem_xml;
  request.out_dir = options_.out_dir.empty() ? "" : options_.out_dir + "/relearn-" + std::to_string(n);
  request.seed = options_.seed + static_cast<std::uint64_t>(n) - 1;
  request.label = "relearn-" + std::to_string(n);
  request.condition.morphology_xml = morphology_xml;
  for (const auto& [id, kind] : motor_defects_) request.condition.motor_defects.emplace_back(id, kind);
  request.condition.module_defects.assign(dead_.begin(), dead_.end());
  request.condition.ground_friction = friction_;
  request.condition.ground_slope = slope_;
  request.condition.ground_slope_direction = slope_direction_;
  request.condition.upside_down = orientation == Orientation::kUpsideDown;
  long long trials = 0;
  const auto wall_start = std::chrono::steady_clock::now();
  const RelearnResult result = relearner_.Relearn(request, [&](const Trial& t) {
    last_robot_time_ = t.time;
    // Life ends at its time limit even in the middle of a relearning (its
    // best so far is kept).
    if (options_.max_life_seconds > 0 && LifeTime(t.time) >= options_.max_life_seconds) {
      relearner_.RequestStop();
    }
    ++trials;
    {
      std::lock_guard lock(mu_);
      ++status_.trials;
      status_.relearn_trials = trials;
      status_.detail = "trial " + std::to_string(trials);
    }
    Row(t.time, t.velocity, t.verification ? "verify" : "");
  });
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  last_robot_time_ = port_.Now();
  // A robot can turn over while it relearns (it walks off a table, 7.5.2):
  // the gait that comes out is stored, and watched, with the orientation the
  // robot has now, not the one it had when the anomaly was assessed.
  const bool reachable = result.error_code != static_cast<int>(StatusCode::kUnavailable);
  if (orientation_watched_ && (result.ok || (reachable && !Stopping()))) {
    const AccelReading now = port_.ReadAccelerometer();
    if (now.valid) last_accel_ = now;
    if (const std::optional<Orientation> turned = Classify(now); turned && *turned != orientation) {
      Event(last_robot_time_, "orientation_changed",
            {{"from", JsonString(OrientationName(orientation))},
             {"to", JsonString(OrientationName(*turned))},
             {"during", JsonString("relearning")}});
      orientation = *turned;
      orientation_ = *turned;
    }
  }
  if (!result.ok) {
    if (result.error_code == static_cast<int>(StatusCode::kUnavailable) && !Stopping()) {
      throw Error(StatusCode::kUnavailable, result.error);  // resumed after the daemon is back
    }
    if (Stopping()) throw Error(StatusCode::kCancelled, "stopped while relearning");
    Log().warn("lifelong: relearning failed: {}", result.error);
    // Walk the warm start, stored so the gait walking is always a stored one;
    // its first window sets its expectation and the monitor's.
    GaitRecord fallback;
    fallback.morphology_key = key;
    fallback.orientation = orientation;
    fallback.config_xml = plan.start_config_xml;
    fallback.problem_xml = plan.problem_xml;
    fallback.use_count = 1;
    fallback.predecessor = current_.id;
    fallback.symptoms = symptoms;
    fallback.origin = "warm start (relearning failed)";
    const std::int64_t id = db_.Insert(fallback);
    Event(last_robot_time_, "relearn_failed",
          {{"run", JsonInt(n)}, {"error", JsonString(result.error)}, {"gait", JsonInt(id)}});
    current_ = Gait{.id = id,
                    .config_xml = plan.start_config_xml,
                    .problem_xml = plan.problem_xml,
                    .key = key,
                    .orientation = orientation};
    port_.Walk(current_.config_xml);
    port_.Settle(options_.settle_periods);
    monitor_.Reset();
    NewGait();
    first_window_ = FirstWindow::kUpdateExpected;
    return;
  }
  GaitRecord record;
  record.morphology_key = key;
  record.orientation = orientation;
  record.config_xml = result.config_xml;
  record.problem_xml = plan.problem_xml;
  record.parameters = result.parameters;
  record.expected_velocity = result.velocity;
  record.use_count = 1;
  record.predecessor = current_.id;
  record.symptoms = symptoms;
  record.origin = relearner_.mode();
  const std::int64_t id = db_.Insert(record);
  Event(last_robot_time_, "relearned",
        {{"run", JsonInt(n)},
         {"gait", JsonInt(id)},
         {"previous", JsonInt(current_.id)},
         {"status", JsonString(result.status)},
         {"velocity", JsonNumber(result.velocity)},
         {"evaluations", JsonInt(result.evaluations)},
         {"trials", JsonInt(result.trials)},
         {"robot_seconds", JsonNumber(result.robot_seconds)},
         {"wall_seconds", JsonNumber(wall)}});
  current_ = Gait{.id = id,
                  .config_xml = result.config_xml,
                  .problem_xml = plan.problem_xml,
                  .key = key,
                  .orientation = orientation,
                  .expected = result.velocity};
  port_.Walk(current_.config_xml);
  port_.Settle(options_.settle_periods);
  // The best of many noisy trials overstates the gait: the next window sets
  // the expectation, the monitor's and the database's.
  monitor_.Reset();
  NewGait();
  first_window_ = FirstWindow::kUpdateExpected;
}

LifeCycle::TrialVerdict LifeCycle::JudgeTrial(const GaitRecord& gait, double mean, double last, int n) const {
  TrialVerdict v;
  const double expected = gait.expected_velocity;
  if (!(expected > 0)) {
    // No positive expectation to judge against: any forward motion will do
    // (as the plain rule: a trial >= recall_accept·E with E <= 0).
    v.accept_level = std::max(0.0, options_.recall_accept * expected);
    v.fail_level = v.accept_level;
    v.accepted = mean > 0 && mean >= options_.recall_accept * expected;
    v.velocity = mean;
    return v;
  }
  const double noise = std::max(0.0, gait.velocity_noise);
  const double root_n = std::sqrt(static_cast<double>(n));
  const double plain = (1 - options_.recall_accept) * expected;
  // The noise of a mean of n windows shrinks as 1/√n (independent windows).
  const double by_noise = std::min(options_.recall_noise_factor * noise / root_n,
                                   (1 - options_.recall_floor) * expected);
  v.accept_level = expected - std::max(plain, by_noise);
  v.fail_level = expected - options_.recall_fail_factor * noise / root_n;
  // A gait is noisy when its noise, not the plain fraction, sets the band.
  const bool noisy = options_.recall_noise_factor * noise > plain;
  if (noisy) {
    v.velocity = mean;
    v.accepted = mean > 0 && mean >= v.accept_level;
    v.longer = !v.accepted && mean > 0 && mean >= v.fail_level && n < options_.recall_max_windows;
    return v;
  }
  // A clean gait is judged on one window; a first window that may have held
  // the start-up from a near standstill gets a second, judged alone.
  v.velocity = last;
  v.fail_level = options_.recall_restart_floor * expected;
  v.accepted = last > 0 && last >= v.accept_level;
  v.longer = !v.accepted && n == 1 && options_.recall_restart_floor > 0 && last > 0 && last >= v.fail_level &&
             options_.recall_max_windows >= 2;
  return v;
}

void LifeCycle::StoreNoise() {
  if (!noise_.valid || noise_.windows == noise_.written_windows) return;
  db_.SetNoise(noise_.gait, noise_.noise, noise_.windows, noise_.ema);
  noise_.written_windows = noise_.windows;
  if (current_.id == noise_.gait) current_.expected = noise_.ema;
}

void LifeCycle::NewGait() {
  noise_ = NoiseSnapshot{};
  orientation_watched_ = up_.has_value();
  orientation_seen_ = 0;
  orientation_flips_ = 0;
}

void LifeCycle::HandleLoss(const std::string& error) {
  SetState("disconnected");
  {
    std::lock_guard lock(mu_);
    ++status_.gaps;
  }
  Log().warn("lifelong: the daemon went away ({}); waiting for it", error);
  Event(last_robot_time_, "daemon_lost", {{"error", JsonString(error)}});
  Row(last_robot_time_, kNaN, "daemon lost");
  const auto wall_start = std::chrono::steady_clock::now();
  const Reattachment r = port_.Reattach(current_.config_xml, [this] { return Stopping(); });
  const double gap = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  if (r.robot_time < last_robot_time_) offset_ += last_robot_time_ - r.robot_time;  // life time goes on
  last_robot_time_ = r.robot_time;
  if (r.restarted) {
    // A new daemon has a new world: what we knew of its faults and ground is gone.
    motor_defects_.clear();
    dead_.clear();
    friction_.reset();
    slope_.reset();
    slope_direction_.reset();
  }
  Event(last_robot_time_, "reattached",
        {{"gap_wall_seconds", JsonNumber(gap)}, {"restarted", JsonBool(r.restarted)}});
  SetState(pending_ || next_ ? "anomaly" : "walking");
  Row(last_robot_time_, kNaN, "reattached after " + FormatRounded(std::round(gap * 10) / 10) + " s");
  // Events of the daemon's own setup; a physical change while we were away.
  std::optional<Anomaly> changed = TakeEvents();
  if (!pending_ && !next_) {
    std::string key;
    CurrentBody(&key);
    if (key != current_.key) {
      next_ = Anomaly{.trigger = "body_changed", .time = last_robot_time_, .velocity_before = monitor_.ema()};
    } else if (changed) {
      next_ = changed;
    }
  }
}

}  // namespace yamor::lifelong
