// The runner's output files: timeline.csv (one row per measurement window
// and trial, plus event rows) and events.jsonl (one JSON object per event),
// both appended and flushed line by line so a killed run keeps its story;
// and timeline.png drawn like thesis Figure 7.4 by tools/plot/plot_timeline.py.
#pragma once

#include <fstream>
#include <string>

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
