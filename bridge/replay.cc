#include "bridge/replay.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

#include "bridge/robot.h"
#include "common/format.h"
#include "common/log.h"
#include "common/status.h"
#include "proto/snp/messages.h"

namespace yamor::bridge {
namespace {

// Frames of one recorded link, from its `open` line (or the header) on.
struct Session {
  snp::RecordAttributes attributes;
  double opened_at = 0.0;
  std::vector<const snp::RecordedFrame*> frames;
};

std::vector<Session> SplitSessions(const snp::Recording& recording) {
  std::vector<Session> sessions;
  for (const snp::RecordEntry& entry : recording.entries) {
    if (const auto* open = std::get_if<snp::RecordedOpen>(&entry)) {
      sessions.push_back(Session{open->attributes, open->time, {}});
      continue;
    }
    if (sessions.empty()) sessions.push_back(Session{recording.header, 0.0, {}});
    sessions.back().frames.push_back(&std::get<snp::RecordedFrame>(entry));
  }
  return sessions;
}

template <typename T>
T ParseNumber(const std::string& text, const char* key, int session) {
  T value{};
  const auto result = std::from_chars(text.data(), text.data() + text.size(), value);
  if (result.ec != std::errc() || result.ptr != text.data() + text.size()) {
    throw Error(StatusCode::kInvalidArgument, "session " + std::to_string(session) +
                                                  ": recorded " + key + "='" + text +
                                                  "' is not a number");
  }
  return value;
}

double Distance(const std::array<double, 3>& a, const std::array<double, 3>& b) {
  return std::hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
}

std::string Describe(const snp::Frame& frame) {
  return std::string(snp::MessageTypeName(frame.type)) + " from " + snp::ToString(frame.source);
}

std::optional<PositionSample> AsPositionSample(const snp::Frame& frame) {
  if (frame.type != snp::MessageType::kRobotPosition) return std::nullopt;
  try {
    const auto position = std::get<snp::RobotPosition>(snp::DecodeMessage(frame));
    return PositionSample{position.time, position.position};
  } catch (const Error& e) {
    Log().warn("replay: undecodable RobotPosition reply: {}", e.what());
    return std::nullopt;
  }
}

// Replays one session into a new robot, appending to `result`.
class SessionReplay {
 public:
  SessionReplay(int index, const Session& session, const ReplayOptions& options,
                ReplayResult& result)
      : index_(index),
        session_(session),
        options_(options),
        result_(result),
        next_row_(options.row_period),
        first_row_(result.rows.size()) {}

  void Run() {
    ReplaySessionSummary summary;
    summary.index = index_;
    summary.opened_at = session_.opened_at;
    summary.timing = ReplayTiming::kClocked;
    for (const snp::RecordedFrame* f : session_.frames) {
      if (f->direction == snp::Direction::kHostToRobot && f->frame.type == snp::MessageType::kStep) {
        summary.timing = ReplayTiming::kStepped;
      }
    }
    RobotOptions robot_options;
    summary.seed = options_.seed.value_or(Attribute<uint64_t>("seed").value_or(0));
    summary.time_step = options_.time_step.value_or(
        Attribute<double>("time_step").value_or(robot_options.world.time_step));
    robot_options.world.seed = summary.seed;
    robot_options.phase_seed = summary.seed;
    robot_options.world.time_step = summary.time_step;
    if (options_.master) {
      robot_options.master = *options_.master;
    } else if (auto master = Attribute<int>("master")) {
      robot_options.master = *master;
    }
    physics::Morphology morphology = LoadMorphology(summary.world);
    Robot robot(std::move(morphology), robot_options);
    robot_ = &robot;
    timing_ = summary.timing;

    std::vector<snp::Frame> recorded;
    std::vector<snp::Frame> replayed;
    for (const snp::RecordedFrame* f : session_.frames) {
      if (f->direction == snp::Direction::kRobotToHost) {
        recorded.push_back(f->frame);
        continue;
      }
      if (timing_ == ReplayTiming::kClocked) AdvanceTo(f->time - session_.opened_at, replayed);
      robot.HandleFrame(f->frame, replayed);
      ++summary.frames_fed;
      EmitRows();
    }
    summary.end_time = robot.Time();
    summary.diverged = diverged_;
    if (diverged_.empty() && robot.world().Diverged()) summary.diverged = "world diverged";
    summary.replies_recorded = recorded.size();
    summary.replies_replayed = replayed.size();
    const std::size_t common = std::min(recorded.size(), replayed.size());
    for (std::size_t i = 0; i < common; ++i) {
      if (recorded[i] == replayed[i]) continue;
      if (summary.replies_differing++ == 0) {
        summary.first_difference = "reply " + std::to_string(i + 1) + ": recorded " +
                                   Describe(recorded[i]) + ", replayed " + Describe(replayed[i]) +
                                   (recorded[i].type == replayed[i].type ? " (payload differs)" : "");
      }
    }

    // Recorded samples against the replay's answers to the same requests.
    // On a real robot the samples would come from the LED tracker instead of
    // RobotPosition replies: feed them here (time since the session opened,
    // central-module position) and sample the replay at their times.
    std::vector<PositionSample> recorded_samples, replayed_samples;
    for (const snp::Frame& f : recorded) {
      if (auto s = AsPositionSample(f)) recorded_samples.push_back(*s);
    }
    for (const snp::Frame& f : replayed) {
      if (auto s = AsPositionSample(f)) replayed_samples.push_back(*s);
    }
    const std::size_t first_sample = result_.samples.size();
    const std::size_t pairs = std::min(recorded_samples.size(), replayed_samples.size());
    for (std::size_t i = 0; i < pairs; ++i) {
      result_.samples.push_back(SampleComparison{
          .session = index_,
          .recorded = recorded_samples[i],
          .replayed = replayed_samples[i],
          .difference = Distance(recorded_samples[i].position, replayed_samples[i].position)});
    }
    result_.unmatched_samples +=
        std::max(recorded_samples.size(), replayed_samples.size()) - pairs;
    for (std::size_t r = first_row_; r < result_.rows.size(); ++r) {
      ReplayRow& row = result_.rows[r];
      double best = std::numeric_limits<double>::infinity();
      for (std::size_t s = first_sample; s < result_.samples.size(); ++s) {
        const double gap = std::abs(result_.samples[s].recorded.time - row.simulated.time);
        if (gap < best) {
          best = gap;
          row.nearest = result_.samples[s];
        }
      }
    }
    result_.sessions.push_back(std::move(summary));
  }

 private:
  template <typename T>
  std::optional<T> Attribute(const char* key) const {
    const std::optional<std::string> text = snp::FindAttribute(session_.attributes, key);
    if (!text) return std::nullopt;
    return ParseNumber<T>(*text, key, index_);
  }

  physics::Morphology LoadMorphology(std::string& name) const {
    const auto need_loader = [this](const std::string& world) {
      if (!options_.load_world) {
        throw Error(StatusCode::kInvalidArgument,
                    "session " + std::to_string(index_) + ": no world loader for '" + world + "'");
      }
      return options_.load_world(world);
    };
    if (options_.world) {
      name = *options_.world;
      return need_loader(*options_.world);
    }
    const std::optional<std::string> world = snp::FindAttribute(session_.attributes, "world");
    if (auto xml = snp::FindAttribute(session_.attributes, "morphology")) {
      name = world.value_or("recorded morphology");
      return physics::Morphology::Parse(
          *xml, "recorded morphology of session " + std::to_string(index_));
    }
    if (world) {
      name = *world;
      return need_loader(*world);
    }
    throw Error(StatusCode::kInvalidArgument,
                "session " + std::to_string(index_) +
                    " records no world or morphology (a real robot?): give a world to replay into");
  }

  // Clocked timing: advances to `target` seconds, taking rows on the way.
  void AdvanceTo(double target, std::vector<snp::Frame>& events) {
    if (!diverged_.empty()) return;
    try {
      while (next_row_ <= target) {
        const double row = next_row_;
        if (row > robot_->Time()) robot_->Advance(row - robot_->Time(), events);
        EmitRows();
        if (next_row_ == row) break;  // did not reach the row (cannot happen: Advance rounds)
      }
      if (target > robot_->Time()) robot_->Advance(target - robot_->Time(), events);
      EmitRows();
    } catch (const Error& e) {
      diverged_ = e.what();
      Log().warn("replay session {}: {}", index_, e.what());
    }
  }

  double HalfStep() const { return 0.5 * robot_->world().options().time_step; }

  void EmitRows() {
    const double now = robot_->Time();
    if (now + HalfStep() < next_row_) return;
    const Eigen::Vector3d p = robot_->world().CentralPosition();
    result_.rows.push_back(ReplayRow{.session = index_,
                                     .simulated = PositionSample{now, {p.x(), p.y(), p.z()}}});
    while (next_row_ <= now + HalfStep()) next_row_ += options_.row_period;
  }

  const int index_;
  const Session& session_;
  const ReplayOptions& options_;
  ReplayResult& result_;
  Robot* robot_ = nullptr;
  ReplayTiming timing_ = ReplayTiming::kStepped;
  double next_row_;               // simulated time of the next table row
  const std::size_t first_row_;   // this session's first row in result_.rows
  std::string diverged_;
};

std::string Fixed(double value, int digits) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", digits, value);
  return buffer;
}

}  // namespace

std::string_view ReplayTimingName(ReplayTiming timing) {
  return timing == ReplayTiming::kStepped ? "stepped" : "clocked";
}

ReplayResult Replay(const snp::Recording& recording, const ReplayOptions& options) {
  if (!(options.row_period > 0.0) || !std::isfinite(options.row_period)) {
    throw Error(StatusCode::kOutOfRange,
                "row period must be finite and > 0, got " + FormatDouble(options.row_period));
  }
  ReplayResult result;
  const std::vector<Session> sessions = SplitSessions(recording);
  for (std::size_t i = 0; i < sessions.size(); ++i) {
    SessionReplay replay(static_cast<int>(i), sessions[i], options, result);
    replay.Run();
  }
  for (const SampleComparison& s : result.samples) {
    result.mean_difference += s.difference;
    result.max_difference = std::max(result.max_difference, s.difference);
  }
  if (!result.samples.empty()) result.mean_difference /= static_cast<double>(result.samples.size());
  return result;
}

std::string FormatReplayCsv(const ReplayResult& result) {
  std::ostringstream out;
  out << "session,time,sim_x,sim_y,sim_z,sample_time,sample_x,sample_y,sample_z,difference\n";
  for (const ReplayRow& row : result.rows) {
    out << row.session << ',' << FormatDouble(row.simulated.time);
    for (double v : row.simulated.position) out << ',' << FormatDouble(v);
    if (row.nearest) {
      out << ',' << FormatDouble(row.nearest->recorded.time);
      for (double v : row.nearest->recorded.position) out << ',' << FormatDouble(v);
      out << ',' << FormatDouble(row.nearest->difference);
    } else {
      out << ",,,,,";
    }
    out << '\n';
  }
  return out.str();
}

std::string FormatReplayReport(const ReplayResult& result) {
  std::ostringstream out;
  for (const ReplaySessionSummary& s : result.sessions) {
    out << "session " << s.index << " (opened at " << Fixed(s.opened_at, 3) << " s): world "
        << s.world << ", seed " << s.seed << ", time step " << FormatDouble(s.time_step)
        << " s, " << ReplayTimingName(s.timing) << " timing\n"
        << "  " << s.frames_fed << " frames fed, " << s.replies_recorded << " replies recorded, "
        << s.replies_replayed << " replayed, " << s.replies_differing << " differing"
        << (s.first_difference.empty() ? "" : " (first: " + s.first_difference + ")") << "\n"
        << "  simulated time at the end: " << Fixed(s.end_time, 3) << " s"
        << (s.diverged.empty() ? "" : "; diverged: " + s.diverged) << "\n";
    out << "  " << "    time      sim x      sim y      sim z |  sample t   sample x   sample y "
        << "  sample z | difference [m]\n";
    for (const ReplayRow& row : result.rows) {
      if (row.session != s.index) continue;
      char line[256];
      std::snprintf(line, sizeof line, "  %8.3f %10.6f %10.6f %10.6f |", row.simulated.time,
                    row.simulated.position[0], row.simulated.position[1],
                    row.simulated.position[2]);
      out << line;
      if (row.nearest) {
        std::snprintf(line, sizeof line, " %9.3f %10.6f %10.6f %10.6f | %.3g",
                      row.nearest->recorded.time, row.nearest->recorded.position[0],
                      row.nearest->recorded.position[1], row.nearest->recorded.position[2],
                      row.nearest->difference);
        out << line << "\n";
      } else {
        out << "  (no recorded sample)\n";
      }
    }
  }
  if (result.samples.empty()) {
    out << "summary: no recorded position samples to compare";
    if (result.unmatched_samples > 0) out << " (" << result.unmatched_samples << " unmatched)";
    out << "\n";
    return out.str();
  }
  out << "summary: " << result.samples.size() << " recorded position samples compared";
  if (result.unmatched_samples > 0) out << " (" << result.unmatched_samples << " unmatched)";
  out << ", mean difference " << FormatDouble(result.mean_difference)
      << " m, max difference " << FormatDouble(result.max_difference) << " m\n";
  return out.str();
}

}  // namespace yamor::bridge
