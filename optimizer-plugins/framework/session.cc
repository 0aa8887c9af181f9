#include "optimizer-plugins/framework/session.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "common/format.h"
#include "common/log.h"
#include "common/status.h"

namespace yamor::optimizer {
namespace {

namespace fs = std::filesystem;

double Seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

std::string CsvField(const std::string& text) {
  if (text.find_first_of(",\"\n") == std::string::npos) return text;
  std::string out = "\"";
  for (char c : text) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}

// A number for the results files: exact, and never NaN or inf (callers check
// values first; this is the last guard of the "no NaN in any output" promise).
std::string OutputNumber(double value) { return FormatDouble(std::isfinite(value) ? value : 0.0); }

}  // namespace

std::string JsonEscape(const std::string& text) {
  std::string out;
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
          std::snprintf(buffer, sizeof(buffer), "\\u%04x", c);
          out += buffer;
        } else {
          out += static_cast<char>(c);
        }
    }
  }
  return out;
}

void WriteFileAtomically(const std::string& path, const std::string& text) {
  const std::string temporary = path + ".tmp";
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    out << text;
    out.flush();
    if (!out) throw Error(StatusCode::kUnavailable, "cannot write " + temporary);
  }
  std::error_code ec;
  fs::rename(temporary, path, ec);
  if (ec) throw Error(StatusCode::kUnavailable, "cannot rename " + temporary + " to " + path + ": " + ec.message());
}

Problem PlainProblem(std::vector<ProblemParameter> parameters) {
  Problem problem;
  std::vector<std::string> names;
  for (const auto& p : parameters) names.push_back(p.name);
  problem.parameters = std::move(parameters);
  problem.to_candidate = [names](const std::vector<double>& x) {
    Candidate c;
    for (std::size_t i = 0; i < names.size(); ++i) c.parameters.emplace_back(names[i], x[i]);
    return c;
  };
  problem.source = "analytic";
  return problem;
}

// The C callbacks of YamorOptimizerContext, forwarding to the session.
struct Session::Callbacks {
  static Session& Of(void* host) { return *static_cast<Session*>(host); }

  static int32_t GetField(void* host, const char* name, const char** value) {
    Session& s = Of(host);
    if (name == nullptr || value == nullptr) return YAMOR_NOT_FOUND;
    auto it = s.fields_.find(name);
    if (it == s.fields_.end()) return YAMOR_NOT_FOUND;
    *value = it->second.c_str();
    return YAMOR_OK;
  }
  static int32_t Evaluate(void* host, const double* points, size_t count, double* values,
                          size_t* evaluated) {
    return Of(host).EvaluatePoints(points, count, values, evaluated);
  }
  static void Progress(void* host, double fraction, const char* status) {
    Session& s = Of(host);
    std::lock_guard lock(s.mu_);
    s.plugin_fraction_ = std::isfinite(fraction) ? std::min(fraction, 1.0) : -1.0;
    s.plugin_status_ = status == nullptr ? "" : status;
  }
  static void LogMessage(void* host, int32_t level, const char* message) {
    Session& s = Of(host);
    const std::string text = "[" + s.options_.label + "] " + (message == nullptr ? "" : message);
    switch (level) {
      case YAMOR_LOG_DEBUG: Log().debug("{}", text); break;
      case YAMOR_LOG_WARNING: Log().warn("{}", text); break;
      case YAMOR_LOG_ERROR: Log().error("{}", text); break;
      default: Log().info("{}", text); break;
    }
  }
  static int32_t StopRequested(void* host) {
    Session& s = Of(host);
    std::lock_guard lock(s.mu_);
    return s.stop_.load() || static_cast<long long>(s.records_.size()) >= s.budget_ ? 1 : 0;
  }
  static uint64_t Random(void* host) { return Of(host).random_(); }
  static const char* LastError(void* host) { return Of(host).last_error_.c_str(); }
};

Session::Session(const LoadedPlugin& plugin, const Problem& problem, Evaluator& evaluator,
                 SessionOptions options)
    : plugin_(plugin), problem_(problem), evaluator_(evaluator), options_(std::move(options)),
      random_(options_.seed) {
  if (problem_.parameters.empty()) {
    throw Error(StatusCode::kInvalidArgument, "the problem has no optimized parameter");
  }
  if (!problem_.to_candidate) {
    throw Error(StatusCode::kInvalidArgument, "the problem has no candidate mapping");
  }
  for (const ProblemParameter& p : problem_.parameters) {
    if (!(std::isfinite(p.min) && std::isfinite(p.max) && p.min < p.max)) {
      throw Error(StatusCode::kInvalidArgument, "parameter " + p.name + " has invalid bounds [" +
                                                    FormatDouble(p.min) + ", " + FormatDouble(p.max) + "]");
    }
    if (!(p.start >= p.min && p.start <= p.max)) {
      throw Error(StatusCode::kInvalidArgument, "parameter " + p.name + " starts at " +
                                                    FormatDouble(p.start) + ", outside [" +
                                                    FormatDouble(p.min) + ", " + FormatDouble(p.max) + "]");
    }
    parameters_.push_back({p.name.c_str(), p.min, p.max, p.start});
  }
  fields_ = ResolveFieldValues(plugin_, options_.set);
  budget_ = std::stoll(fields_.at(kMaxEvaluationsField));
  if (options_.resume && !options_.out_dir.empty()) LoadRecord();
}

RunIdentity Session::Identity() const {
  RunIdentity identity = options_.identity;
  identity["plugin"] = plugin_.name() + " " + plugin_.version();
  if (!plugin_.path().empty()) {
    try {
      identity["plugin_file"] = FileFingerprint(plugin_.path());
    } catch (const Error&) {
      identity["plugin_file"] = "unreadable";
    }
  }
  identity["seed"] = std::to_string(options_.seed);
  for (const auto& [name, value] : fields_) identity["field." + name] = value;
  std::string parameters;
  for (const ProblemParameter& p : problem_.parameters) {
    parameters += (parameters.empty() ? "" : "; ") + p.name + " in [" + FormatDouble(p.min) +
                  ", " + FormatDouble(p.max) + "] from " + FormatDouble(p.start);
  }
  identity["parameters"] = parameters;
  return identity;
}

void Session::LoadRecord() {
  const fs::path dir(options_.out_dir);
  const std::string run_path = (dir / "run.toml").string();
  const std::string csv_path = (dir / "evaluations.csv").string();
  std::error_code ec;
  if (!fs::exists(run_path, ec)) {
    if (fs::exists(csv_path, ec) && fs::file_size(csv_path, ec) > 0) {
      throw Error(StatusCode::kFailedPrecondition,
                  "cannot resume " + options_.out_dir +
                      ": it holds evaluations.csv but no run.toml (a folder of an older "
                      "yamor-optimize, or no results folder), so the run cannot be checked");
    }
    Log().info("[{}] {}: nothing recorded yet; starting the run", options_.label,
               options_.out_dir);
    return;
  }
  std::map<std::string, std::string> info;
  const RunIdentity recorded = ReadRunFile(run_path, &info);
  const std::string differences = IdentityDifferences(recorded, Identity());
  if (!differences.empty()) {
    std::string message = "cannot resume " + options_.out_dir +
                          ": this is not the recorded run (" + differences + ")";
    if (const auto it = info.find("command"); it != info.end()) {
      message += "; it was started as: " + it->second;
    }
    throw Error(StatusCode::kFailedPrecondition, message);
  }
  replay_has_run_file_ = true;
  EvaluationRecordFile record = ReadEvaluationRecord(csv_path);
  if (static_cast<long long>(record.rows.size()) > budget_) {
    throw Error(StatusCode::kFailedPrecondition,
                "cannot resume " + options_.out_dir + ": evaluations.csv holds " +
                    std::to_string(record.rows.size()) + " evaluations, more than the budget " +
                    std::to_string(budget_));
  }
  replay_ = std::move(record.rows);
  replay_columns_ = std::move(record.columns);
  replay_valid_bytes_ = record.valid_bytes;
  replay_torn_ = record.torn;
  replay_torn_reason_ = record.torn_reason;
}

std::string Session::CheckRecorded(const Candidate& candidate,
                                   const RecordedEvaluation& row) const {
  bool same = candidate.parameters.size() == replay_columns_.size() &&
              row.values.size() == replay_columns_.size();
  for (std::size_t i = 0; same && i < replay_columns_.size(); ++i) {
    same = candidate.parameters[i].first == replay_columns_[i] &&
           candidate.parameters[i].second == row.values[i];
  }
  if (same) return "";
  std::string asked;
  for (const auto& [name, value] : candidate.parameters) {
    asked += (asked.empty() ? "" : ", ") + name + "=" + FormatDouble(value);
  }
  std::string recorded;
  for (std::size_t i = 0; i < replay_columns_.size() && i < row.values.size(); ++i) {
    recorded += (recorded.empty() ? "" : ", ") + replay_columns_[i] + "=" +
                FormatDouble(row.values[i]);
  }
  return "resuming: evaluation " + std::to_string(row.index) + " asks for {" + asked +
         "} but evaluations.csv recorded {" + recorded +
         "}: the run does not follow its record (is the plugin deterministic for its seed?)";
}

Session::~Session() = default;

int32_t Session::EvaluatePoints(const double* points, std::size_t count, double* values,
                                std::size_t* evaluated) {
  if (evaluated != nullptr) *evaluated = 0;
  const std::size_t dimension = parameters_.size();
  if (count == 0) return YAMOR_OK;
  if (points == nullptr || values == nullptr) {
    last_error_ = "evaluate called with null points or values";
    return YAMOR_FAILED;
  }
  // Validate the whole batch before anything runs: a plugin bug must not
  // half-spend a batch.
  std::vector<std::vector<double>> batch_points(count);
  for (std::size_t k = 0; k < count; ++k) {
    batch_points[k].assign(points + k * dimension, points + (k + 1) * dimension);
    for (std::size_t i = 0; i < dimension; ++i) {
      const double v = batch_points[k][i];
      const YamorParameter& p = parameters_[i];
      if (!(v >= p.min && v <= p.max)) {
        last_error_ = "candidate " + std::to_string(k) + " of the batch sets " + p.name + " = " +
                      (std::isfinite(v) ? FormatDouble(v) : std::string(std::isnan(v) ? "NaN" : "inf")) +
                      ", outside [" + FormatDouble(p.min) + ", " + FormatDouble(p.max) + "]";
        return YAMOR_FAILED;
      }
    }
  }
  std::size_t allowed = count;
  {
    std::lock_guard lock(mu_);
    const long long remaining = budget_ - static_cast<long long>(records_.size());
    if (stop_.load() || remaining <= 0) return YAMOR_STOPPED;
    allowed = std::min<std::size_t>(count, static_cast<std::size_t>(remaining));
  }
  batch_points.resize(allowed);
  std::vector<Candidate> batch;
  batch.reserve(allowed);
  try {
    for (const auto& p : batch_points) batch.push_back(problem_.to_candidate(p));
  } catch (const std::exception& e) {
    last_error_ = std::string("cannot build the candidate: ") + e.what();
    return YAMOR_FAILED;
  }
  // Resuming: the first requests are answered from the record.
  std::vector<Evaluation> results(allowed);
  std::size_t replayed = 0;
  std::size_t first = 0;
  {
    std::lock_guard lock(mu_);
    first = records_.size();
  }
  while (replayed < allowed && first + replayed < replay_.size()) {
    const RecordedEvaluation& row = replay_[first + replayed];
    if (const std::string why = CheckRecorded(batch[replayed], row); !why.empty()) {
      last_error_ = why;
      return YAMOR_FAILED;
    }
    results[replayed] = row.evaluation;
    ++replayed;
  }
  try {
    if (replayed < allowed) {
      const std::vector<Candidate> fresh(batch.begin() + static_cast<std::ptrdiff_t>(replayed),
                                         batch.end());
      std::vector<Evaluation> evaluated = evaluator_.EvaluateBatch(fresh);
      YAMOR_CHECK(evaluated.size() == fresh.size(),
                  "an evaluator returned a result per candidate");
      std::move(evaluated.begin(), evaluated.end(),
                results.begin() + static_cast<std::ptrdiff_t>(replayed));
    }
  } catch (const Error& e) {
    if (e.code() == StatusCode::kCancelled) return YAMOR_STOPPED;
    last_error_ = std::string(StatusCodeName(e.code())) + ": " + e.what();
    return YAMOR_FAILED;
  } catch (const std::exception& e) {
    last_error_ = e.what();
    return YAMOR_FAILED;
  }
  for (std::size_t k = 0; k < results.size(); ++k) {
    if (!std::isfinite(results[k].velocity)) {
      last_error_ = "evaluation of candidate " + std::to_string(k) + " returned a non-finite value";
      return YAMOR_FAILED;
    }
  }
  Record(batch_points, batch, results, values, replayed);
  if (evaluated != nullptr) *evaluated = allowed;
  return allowed < count ? YAMOR_STOPPED : YAMOR_OK;
}

void Session::Record(const std::vector<std::vector<double>>& points,
                     const std::vector<Candidate>& batch, const std::vector<Evaluation>& results,
                     double* values, std::size_t replayed) {
  std::vector<double> improved;
  {
    std::lock_guard lock(mu_);
    for (std::size_t k = 0; k < results.size(); ++k) {
      EvaluationRecord record;
      record.index = static_cast<long long>(records_.size());
      record.point = points[k];
      record.evaluation = results[k];
      values[k] = results[k].velocity;
      if (!best_.has_best || results[k].velocity > best_.best_velocity) {
        best_.has_best = true;
        best_.best_velocity = results[k].velocity;
        best_.best_index = record.index;
        best_.best_point = points[k];
        improved = points[k];
      }
      if (csv_.is_open() && k >= replayed) {  // recorded rows are in the file already
        if (csv_columns_.empty()) {
          csv_ << "index";
          for (const auto& [name, value] : batch[k].parameters) {
            csv_columns_.push_back(name);
            csv_ << ',' << CsvField(name);
          }
          csv_ << ",velocity,distance,diverged,host,wall_seconds"
               << (options_.live ? ",robot_seconds\n" : "\n");
        }
        csv_ << record.index;
        for (const auto& [name, value] : batch[k].parameters) csv_ << ',' << OutputNumber(value);
        csv_ << ',' << OutputNumber(results[k].velocity) << ',' << OutputNumber(results[k].distance)
             << ',' << (results[k].diverged ? 1 : 0) << ',' << CsvField(results[k].host) << ','
             << OutputNumber(results[k].wall_seconds);
        if (options_.live) csv_ << ',' << OutputNumber(results[k].robot_seconds);
        csv_ << '\n';
      }
      records_.push_back(std::move(record));
    }
    if (csv_.is_open()) csv_.flush();
  }
  if (!improved.empty()) {
    try {
      WriteBest(improved);
    } catch (const std::exception& e) {
      Log().warn("[{}] cannot write best.xml: {}", options_.label, e.what());
    }
  }
}

void Session::WriteBest(const std::vector<double>& point) const {
  if (options_.out_dir.empty() || !problem_.config_xml) return;
  WriteFileAtomically((fs::path(options_.out_dir) / "best.xml").string(), problem_.config_xml(point));
}

SessionResult Session::Run() {
  {
    std::lock_guard lock(mu_);
    start_ = std::chrono::steady_clock::now();
  }
  if (!options_.out_dir.empty()) {
    std::error_code ec;
    fs::create_directories(options_.out_dir, ec);
    if (ec) throw Error(StatusCode::kInvalidArgument, "cannot create results folder " + options_.out_dir + ": " + ec.message());
    const std::string csv_path = (fs::path(options_.out_dir) / "evaluations.csv").string();
    const bool append = replay_has_run_file_ && replay_valid_bytes_ > 0;
    if (append) {
      if (replay_torn_) {
        // A kill mid-write leaves a partial last line: cut it off so the
        // file ends as if the run had never stopped.
        Log().warn("[{}] {}: dropping a torn last line ({})", options_.label, csv_path,
                   replay_torn_reason_);
        fs::resize_file(csv_path, replay_valid_bytes_, ec);
        if (ec) throw Error(StatusCode::kInvalidArgument, "cannot truncate " + csv_path + ": " + ec.message());
      }
      Log().info("[{}] resuming {}: {} evaluations recorded", options_.label, options_.out_dir,
                 replay_.size());
    } else {
      std::map<std::string, std::string> info = options_.info;
      info["problem"] = problem_.source;
      WriteRunFile((fs::path(options_.out_dir) / "run.toml").string(), Identity(), info);
    }
    std::lock_guard lock(mu_);
    if (append) csv_columns_ = replay_columns_;
    csv_.open(csv_path, append ? std::ios::app : std::ios::trunc);
    if (!csv_) throw Error(StatusCode::kInvalidArgument, "cannot write " + csv_path);
  }

  YamorOptimizerContext context{};
  context.abi_version = YAMOR_OPTIMIZER_ABI_VERSION;
  context.struct_size = sizeof(YamorOptimizerContext);
  context.host = this;
  context.parameter_count = parameters_.size();
  context.parameters = parameters_.data();
  context.seed = options_.seed;
  context.get_field = &Callbacks::GetField;
  context.evaluate = &Callbacks::Evaluate;
  context.progress = &Callbacks::Progress;
  context.log = &Callbacks::LogMessage;
  context.stop_requested = &Callbacks::StopRequested;
  context.random = &Callbacks::Random;
  context.last_error = &Callbacks::LastError;

  Log().info("[{}] {} {} starts: {} parameters, budget {} evaluations, seed {}", options_.label,
             plugin_.name(), plugin_.version(), parameters_.size(), budget_, options_.seed);
  char error[1024] = {0};
  int32_t status = YAMOR_FAILED;
  try {
    status = plugin_.api().run(&context, error, sizeof(error));
  } catch (...) {
    // The ABI is C: an exception crossing it is the plugin's bug.
    std::snprintf(error, sizeof(error), "the plugin let an exception escape its run callback");
    status = YAMOR_FAILED;
  }
  error[sizeof(error) - 1] = '\0';

  SessionResult result;
  {
    std::lock_guard lock(mu_);
    result.has_best = best_.has_best;
    result.best_velocity = best_.best_velocity;
    result.best_index = best_.best_index;
    result.best_point = best_.best_point;
    result.evaluations = static_cast<long long>(records_.size());
    for (const EvaluationRecord& r : records_) result.robot_seconds += r.evaluation.robot_seconds;
    if (csv_.is_open()) csv_.close();
  }
  result.wall_seconds = Seconds(start_);  // only Run writes start_
  if (result.evaluations < static_cast<long long>(replay_.size()) && status != YAMOR_FAILED &&
      !stop_.load()) {
    // The plugin stopped before reaching the end of its record.
    std::snprintf(error, sizeof(error),
                  "resuming: the plugin ended after %lld evaluations but evaluations.csv "
                  "recorded %zu: the run does not follow its record",
                  result.evaluations, replay_.size());
    status = YAMOR_FAILED;
  }
  if (status == YAMOR_OK) {
    result.status = "converged";
  } else if (status == YAMOR_STOPPED) {
    result.status = result.evaluations >= budget_ ? "budget" : "stopped";
  } else {
    result.status = "failed";
    result.error = error[0] != '\0' ? error : "the plugin failed without a message";
  }
  if (result.status == "failed") {
    Log().error("[{}] {} failed after {} evaluations: {}", options_.label, plugin_.name(),
                result.evaluations, result.error);
  } else {
    Log().info("[{}] {} ended ({}) after {} evaluations; best velocity {:.4f} m/s", options_.label,
               plugin_.name(), result.status, result.evaluations, result.best_velocity);
  }
  if (!options_.out_dir.empty()) {
    try {
      WriteSummary(result);
    } catch (const std::exception& e) {
      Log().error("[{}] cannot write summary.json: {}", options_.label, e.what());
    }
  }
  return result;
}

void Session::WriteSummary(const SessionResult& result) const {
  std::ostringstream j;
  j << "{\n";
  j << "  \"label\": \"" << JsonEscape(options_.label) << "\",\n";
  j << "  \"plugin\": {\"name\": \"" << JsonEscape(plugin_.name()) << "\", \"version\": \""
    << JsonEscape(plugin_.version()) << "\", \"path\": \"" << JsonEscape(plugin_.path()) << "\"},\n";
  j << "  \"fields\": {";
  bool first = true;
  for (const auto& [name, value] : fields_) {
    j << (first ? "" : ", ") << "\"" << JsonEscape(name) << "\": \"" << JsonEscape(value) << "\"";
    first = false;
  }
  j << "},\n";
  j << "  \"problem\": \"" << JsonEscape(problem_.source) << "\",\n";
  j << "  \"evaluator\": \"" << JsonEscape(options_.evaluator_description) << "\",\n";
  j << "  \"live\": " << (options_.live ? "true" : "false") << ",\n";
  j << "  \"seed\": " << options_.seed << ",\n";
  j << "  \"status\": \"" << result.status << "\",\n";
  j << "  \"error\": \"" << JsonEscape(result.error) << "\",\n";
  j << "  \"evaluations\": " << result.evaluations << ",\n";
  j << "  \"wall_seconds\": " << OutputNumber(result.wall_seconds) << ",\n";
  j << "  \"robot_seconds\": " << OutputNumber(result.robot_seconds) << ",\n";
  j << "  \"evaluations_per_second\": "
    << OutputNumber(result.wall_seconds > 0 ? result.evaluations / result.wall_seconds : 0.0) << ",\n";
  j << "  \"parameters\": [";
  for (std::size_t i = 0; i < problem_.parameters.size(); ++i) {
    const ProblemParameter& p = problem_.parameters[i];
    j << (i == 0 ? "" : ", ") << "{\"name\": \"" << JsonEscape(p.name) << "\", \"min\": "
      << OutputNumber(p.min) << ", \"max\": " << OutputNumber(p.max) << ", \"start\": "
      << OutputNumber(p.start) << "}";
  }
  j << "],\n";
  if (result.has_best) {
    j << "  \"best\": {\"index\": " << result.best_index << ", \"velocity\": "
      << OutputNumber(result.best_velocity) << ", \"point\": {";
    for (std::size_t i = 0; i < result.best_point.size(); ++i) {
      j << (i == 0 ? "" : ", ") << "\"" << JsonEscape(problem_.parameters[i].name)
        << "\": " << OutputNumber(result.best_point[i]);
    }
    j << "}}\n";
  } else {
    j << "  \"best\": null\n";
  }
  j << "}\n";
  WriteFileAtomically((fs::path(options_.out_dir) / "summary.json").string(), j.str());
}

SessionSnapshot Session::Snapshot() const {
  std::lock_guard lock(mu_);
  SessionSnapshot s;
  s.evaluations = static_cast<long long>(records_.size());
  s.budget = budget_;
  s.has_best = best_.has_best;
  s.best_velocity = best_.best_velocity;
  s.plugin_fraction = plugin_fraction_;
  s.plugin_status = plugin_status_;
  s.elapsed_seconds = start_.time_since_epoch().count() == 0 ? 0.0 : Seconds(start_);
  return s;
}

std::vector<EvaluationRecord> Session::Records() const {
  std::lock_guard lock(mu_);
  return records_;
}

}  // namespace yamor::optimizer
