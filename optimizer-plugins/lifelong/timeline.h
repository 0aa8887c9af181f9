// The runner's output files: timeline.csv (one row per measurement window
// and trial, plus event rows) and events.jsonl (one JSON object per event),
// both appended and flushed line by line so a killed run keeps its story;
// and timeline.png drawn like thesis Figure 7.4 by tools/plot/plot_timeline.py.
#pragma once

#include <fstream>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "optimizer-plugins/lifelong/robot_port.h"

namespace yamor::lifelong {

/// timeline.csv's header line (without the newline).
inline constexpr const char* kTimelineHeader = "time,velocity,ema,state,event,gait";

/// Writes `dir`/timeline.csv and `dir`/events.jsonl, appending to files a
/// previous run left (a header is written only to a new timeline.csv).
///
/// Thread safety: one thread at a time.
class TimelineWriter final : public LifeLog {
 public:
  /// Opens both files. Throws yamor::Error kUnavailable naming the file
  /// when one cannot be opened, kFailedPrecondition when timeline.csv exists
  /// with another header.
  explicit TimelineWriter(const std::string& dir);

  void Row(const TimelineRow& row) override;
  void Event(const LifeEvent& event) override;

 private:
  std::string dir_;
  std::ofstream timeline_;
  std::ofstream events_;
};

/// The events FramingLog takes a picture at by default: the key moments of
/// a life (thesis Figure 7.4's story).
inline const std::vector<std::string> kFramedEvents = {"anomaly", "recalled", "relearned"};

/// A LifeLog that also saves a picture of the robot at the key moments:
/// for an event of one of `kinds` it asks `take_frame` for PNG bytes (the
/// robot as it is now), writes them to `dir`/frames/KIND-NN.png (NN counts
/// per kind from 01) and adds `"frame": "frames/KIND-NN.png"` to the event
/// before handing it to `inner`. A frame that cannot be taken or written
/// (no renderer, a real robot, a full disk) changes nothing else: the event
/// goes on without the field, and a warning is logged once.
///
/// Thread safety: one thread at a time (as LifeLog).
class FramingLog final : public LifeLog {
 public:
  /// `inner` outlives the object.
  FramingLog(LifeLog& inner, std::string dir, std::function<std::string()> take_frame,
             std::vector<std::string> kinds = kFramedEvents);

  void Row(const TimelineRow& row) override { inner_.Row(row); }
  void Event(const LifeEvent& event) override;

  /// Frames written so far.
  int frames() const { return frames_; }
  /// Frames that could not be taken or written.
  int failures() const { return failures_; }

 private:
  LifeLog& inner_;
  std::string dir_;
  std::function<std::string()> take_frame_;
  std::vector<std::string> kinds_;
  std::map<std::string, int> counts_;
  int frames_ = 0;
  int failures_ = 0;
};

/// One timeline.csv line for `row` (no newline): numbers in full precision,
/// empty for NaN; text fields quoted when they hold a comma or a quote.
std::string TimelineLine(const TimelineRow& row);

/// One events.jsonl line for `event` (no newline).
std::string EventLine(const LifeEvent& event);

/// Draws `dir`/timeline.png from `dir`/timeline.csv with `python` running
/// `script` (see optimizer::PlotProgress). Fails softly: returns false and
/// logs a warning.
bool PlotTimeline(const std::string& dir, const std::string& title, const std::string& script,
                  const std::string& python);

}  // namespace yamor::lifelong
