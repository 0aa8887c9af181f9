#include "optimizer-plugins/lifelong/session_relearner.h"

#include <algorithm>
#include <cmath>

#include "common/format.h"
#include "common/log.h"
#include "common/status.h"
#include "cpg/config_xml.h"
#include "optimizer-plugins/framework/optimization_config.h"
#include "optimizer-plugins/framework/run_setup.h"

namespace yamor::lifelong {
namespace {

// Model mode evaluates on a host pool whose workers run a batch at once, but
// powell's default line search (brent) asks for one candidate at a time and
// leaves all workers but one idle. A plugin offering a batch line search
// gets it in model mode unless --set chooses: the 7.5.1 transformation
// relearned with 150 evaluations on one daemon's 2 workers in 57 s instead
// of 96 s of wall time, 6.64 against 4.20 cm/s (400: 150 s against 184 s,
// 8.02 against 8.40; docs/benchmarks.md, "Lifelong learning"). Online, a
// trial is one at a time either way and brent needs fewer of them.
constexpr const char* kLineSearchField = "line_search";
constexpr const char* kBatchLineSearch = "interval";

// Runs each candidate of a batch as one trial on the robot: the scenario
// hook first, then the live evaluator, then the runner hears of it. Keeps
// the code of the last failure so the runner can tell a lost daemon.
class TrialEvaluator final : public optimizer::Evaluator {
 public:
  TrialEvaluator(DaemonPort& port, optimizer::LiveEvaluator& live, std::function<void(const Trial&)> on_trial,
                 bool verification)
      : port_(port), live_(live), on_trial_(std::move(on_trial)), verification_(verification) {}

  std::vector<optimizer::Evaluation> EvaluateBatch(const std::vector<optimizer::Candidate>& batch) override {
    std::vector<optimizer::Evaluation> out;
    for (const optimizer::Candidate& c : batch) {
      try {
        port_.BeforeMotion();
        const double start = port_.Now();
        const std::vector<optimizer::Evaluation> one = live_.EvaluateBatch({c});
        const double end = port_.Now();
        out.push_back(one.at(0));
        ++trials_;
        robot_seconds_ += end - start;
        on_trial_(Trial{.time = end, .velocity = one.at(0).velocity, .verification = verification_});
      } catch (const Error& e) {
        last_code_ = static_cast<int>(e.code());
        throw;
      }
    }
    return out;
  }
  void RequestStop() override { live_.RequestStop(); }
  int Capacity() const override { return 1; }

  int last_code() const { return last_code_; }
  long long trials() const { return trials_; }
  double robot_seconds() const { return robot_seconds_; }

 private:
  DaemonPort& port_;
  optimizer::LiveEvaluator& live_;
  std::function<void(const Trial&)> on_trial_;
  bool verification_;
  int last_code_ = 0;
  long long trials_ = 0;
  double robot_seconds_ = 0;
};

// Copies the robot's condition into the pool's evaluation settings.
void ApplyCondition(optimizer::EvaluationSettings& settings, const RobotCondition& condition) {
  settings.morphology_xml = condition.morphology_xml;
  for (const auto& [id, kind] : condition.motor_defects) {
    settings.motor_defects.emplace_back(
        id, kind == "stuck" ? optimizer::MotorDefect::kStuck : optimizer::MotorDefect::kLimp);
  }
  settings.module_defects = condition.module_defects;
  settings.ground_friction = condition.ground_friction;
  settings.ground_slope = condition.ground_slope;
  settings.ground_slope_direction = condition.ground_slope_direction;
  settings.upside_down = condition.upside_down;
}

std::vector<std::pair<std::string, double>> Named(const optimizer::OptimizationConfig& config,
                                                  const std::vector<double>& point) {
  std::vector<std::pair<std::string, double>> out;
  for (std::size_t i = 0; i < point.size() && i < config.optimized().size(); ++i) {
    out.emplace_back(config.optimized()[i].param, point[i]);
  }
  return out;
}

}  // namespace

void ValidateRelearnerOptions(const RelearnerOptions& options) {
  if (options.mode != "online" && options.mode != "model") {
    throw Error(StatusCode::kInvalidArgument, "relearning mode \"" + options.mode + "\" is not online or model");
  }
  if (options.online_budget < 1) {
    throw Error(StatusCode::kInvalidArgument,
                "online budget " + std::to_string(options.online_budget) + " must be >= 1 trial");
  }
  if (options.model_budget < 1) {
    throw Error(StatusCode::kInvalidArgument,
                "model budget " + std::to_string(options.model_budget) + " must be >= 1 evaluation");
  }
  if (options.verify < 1) {
    throw Error(StatusCode::kInvalidArgument, "verified candidates " + std::to_string(options.verify) + " must be >= 1");
  }
  if (!(options.model_warmup >= 0 && options.model_duration > 0 && std::isfinite(options.model_warmup) &&
        std::isfinite(options.model_duration))) {
    throw Error(StatusCode::kInvalidArgument, "model warm-up must be >= 0 and model duration > 0");
  }
}

SessionRelearner::SessionRelearner(DaemonPort& port, RelearnerOptions options)
    : port_(port), options_(std::move(options)) {
  ValidateRelearnerOptions(options_);
  std::vector<std::string> dirs = options_.plugin_dirs;
  for (const auto& d : optimizer::DefaultPluginDirs()) dirs.push_back(d);
  plugin_ = optimizer::LoadedPlugin::Load(optimizer::FindPlugin(options_.plugin, dirs));
  optimizer::ResolveFieldValues(plugin_, Fields());
}

SessionRelearner::~SessionRelearner() = default;

std::map<std::string, std::string> SessionRelearner::Fields() const {
  std::map<std::string, std::string> set = options_.set;
  if (!set.count(optimizer::kMaxEvaluationsField)) {
    set[optimizer::kMaxEvaluationsField] =
        std::to_string(options_.mode == "online" ? options_.online_budget : options_.model_budget);
  }
  if (options_.mode == "model" && !set.count(kLineSearchField)) {
    for (const optimizer::FieldSpec& f : plugin_.fields()) {
      if (f.name == kLineSearchField &&
          std::find(f.choices.begin(), f.choices.end(), kBatchLineSearch) != f.choices.end()) {
        set[kLineSearchField] = kBatchLineSearch;
      }
    }
  }
  return set;
}

void SessionRelearner::RequestStop() {
  std::lock_guard lock(mu_);
  stop_ = true;
  if (session_) session_->RequestStop();
  if (evaluator_) evaluator_->RequestStop();
}

RelearnResult SessionRelearner::Relearn(const RelearnRequest& request,
                                        const std::function<void(const Trial&)>& on_trial) {
  {
    std::lock_guard lock(mu_);
    if (stop_) {
      RelearnResult r;
      r.status = "stopped";
      r.error = "stopped before relearning";
      r.error_code = static_cast<int>(StatusCode::kCancelled);
      return r;
    }
  }
  try {
    return options_.mode == "online" ? Online(request, on_trial) : Model(request, on_trial);
  } catch (const Error& e) {
    RelearnResult r;
    r.status = "failed";
    r.error = e.what();
    r.error_code = static_cast<int>(e.code());
    return r;
  }
}

RelearnResult SessionRelearner::Online(const RelearnRequest& request,
                                       const std::function<void(const Trial&)>& on_trial) {
  const optimizer::OptimizationConfig config =
      optimizer::OptimizationConfig::Parse(request.problem_xml, request.label + " problem");
  const optimizer::Problem problem = optimizer::MakeProblem(config);
  std::unique_ptr<optimizer::LiveEvaluator> live = port_.NewLiveEvaluator();
  TrialEvaluator trials(port_, *live, on_trial, /*verification=*/false);
  optimizer::Session session(plugin_, problem, trials,
                             {.label = request.label,
                              .seed = request.seed,
                              .set = Fields(),
                              .out_dir = request.out_dir,
                              .evaluator_description = "live robot at " + port_.address().ToString()});
  {
    std::lock_guard lock(mu_);
    session_ = &session;
    evaluator_ = &trials;
    if (stop_) session.RequestStop();
  }
  const optimizer::SessionResult s = session.Run();
  {
    std::lock_guard lock(mu_);
    session_ = nullptr;
    evaluator_ = nullptr;
  }
  RelearnResult r;
  r.status = s.status;
  r.evaluations = s.evaluations;
  r.trials = trials.trials();
  r.robot_seconds = trials.robot_seconds();
  if (!s.has_best) {
    r.error = s.error.empty() ? "no evaluation finished" : s.error;
    r.error_code = trials.last_code() ? trials.last_code() : static_cast<int>(StatusCode::kInternal);
    return r;
  }
  if (s.status == "failed" && trials.last_code() == static_cast<int>(StatusCode::kUnavailable)) {
    r.error = s.error;  // the daemon went away: the adaptation is resumed when it is back
    r.error_code = trials.last_code();
    return r;
  }
  r.ok = true;
  r.config_xml = cpg::WriteConfigXml(config.Apply(s.best_point));
  r.parameters = Named(config, s.best_point);
  r.velocity = s.best_velocity;
  return r;
}

RelearnResult SessionRelearner::Model(const RelearnRequest& request,
                                      const std::function<void(const Trial&)>& on_trial) {
  const optimizer::OptimizationConfig config =
      optimizer::OptimizationConfig::Parse(request.problem_xml, request.label + " problem");
  const optimizer::Problem problem = optimizer::MakeProblem(config);
  optimizer::EvaluationSettings settings;
  settings.config_xml = config.RobotXml();
  settings.warmup = options_.model_warmup;
  settings.duration = options_.model_duration;
  settings.seed = options_.model_seed;
  ApplyCondition(settings, request.condition);
  std::vector<optimizer::HostAddress> hosts = options_.model_hosts;
  if (hosts.empty()) hosts.push_back(port_.address());
  std::string host_list;
  for (const auto& h : hosts) host_list += (host_list.empty() ? "" : ",") + h.ToString();

  RelearnResult r;
  std::vector<optimizer::EvaluationRecord> records;
  optimizer::SessionResult s;
  {
    optimizer::HostPool pool(hosts, settings, options_.pool);
    optimizer::Session session(plugin_, problem, pool,
                               {.label = request.label,
                                .seed = request.seed,
                                .set = Fields(),
                                .out_dir = request.out_dir,
                                .evaluator_description = "model of the robot on " + host_list});
    {
      std::lock_guard lock(mu_);
      session_ = &session;
      evaluator_ = &pool;
      if (stop_) session.RequestStop();
    }
    s = session.Run();
    records = session.Records();
    std::lock_guard lock(mu_);
    session_ = nullptr;
    evaluator_ = nullptr;
  }
  r.status = s.status;
  r.evaluations = s.evaluations;
  if (!s.has_best) {
    r.error = s.error.empty() ? "no model evaluation finished" : s.error;
    r.error_code = static_cast<int>(StatusCode::kInternal);
    return r;
  }
  // The best few distinct candidates of the model, verified on the robot.
  std::sort(records.begin(), records.end(), [](const auto& a, const auto& b) {
    return a.evaluation.velocity > b.evaluation.velocity;
  });
  std::vector<std::vector<double>> chosen;
  for (const auto& rec : records) {
    if (static_cast<int>(chosen.size()) >= options_.verify) break;
    if (rec.evaluation.diverged) continue;
    if (std::find(chosen.begin(), chosen.end(), rec.point) == chosen.end()) chosen.push_back(rec.point);
  }
  std::unique_ptr<optimizer::LiveEvaluator> live = port_.NewLiveEvaluator();
  TrialEvaluator verify(port_, *live, on_trial, /*verification=*/true);
  {
    std::lock_guard lock(mu_);
    evaluator_ = &verify;
    if (stop_) verify.RequestStop();
  }
  double best = -1e300;
  std::vector<double> best_point;
  for (const auto& point : chosen) {
    try {
      const double v = verify.EvaluateBatch({problem.to_candidate(point)}).at(0).velocity;
      if (v > best) {
        best = v;
        best_point = point;
      }
    } catch (const Error& e) {
      std::lock_guard lock(mu_);
      evaluator_ = nullptr;
      if (best_point.empty() || e.code() == StatusCode::kUnavailable) throw;
      break;  // stopped: keep the best verified so far
    }
  }
  {
    std::lock_guard lock(mu_);
    evaluator_ = nullptr;
  }
  r.trials = verify.trials();
  r.robot_seconds = verify.robot_seconds();
  r.ok = true;
  r.config_xml = cpg::WriteConfigXml(config.Apply(best_point));
  r.parameters = Named(config, best_point);
  r.velocity = best;
  Log().info("lifelong: {}: model best {} cm/s, verified best {} cm/s on the robot", request.label,
             FormatRounded(s.best_velocity * 100), FormatRounded(best * 100));
  return r;
}

}  // namespace yamor::lifelong
