#include "optimizer-plugins/lifelong/timeline.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "common/format.h"
#include "common/log.h"
#include "common/status.h"
#include "optimizer-plugins/framework/progress.h"

namespace yamor::lifelong {
namespace {

std::string CsvText(const std::string& text) {
  if (text.find_first_of(",\"\n") == std::string::npos) return text;
  std::string out = "\"";
  for (char c : text) {
    if (c == '"') out += '"';
    out += c == '\n' ? ' ' : c;
  }
  return out + "\"";
}

std::string CsvNumber(double v) { return std::isfinite(v) ? FormatDouble(v) : ""; }

}  // namespace

std::string TimelineLine(const TimelineRow& row) {
  return CsvNumber(row.time) + "," + CsvNumber(row.velocity) + "," + CsvNumber(row.ema) + "," +
         CsvText(row.state) + "," + CsvText(row.event) + "," + std::to_string(row.gait);
}

std::string EventLine(const LifeEvent& event) {
  std::string line = "{\"time\":" + JsonNumber(event.time) + ",\"kind\":" + JsonString(event.kind);
  for (const auto& [key, value] : event.fields) {
    line += ',';
    line += JsonString(key);
    line += ':';
    line += value;
  }
  return line + "}";
}

TimelineWriter::TimelineWriter(const std::string& dir) : dir_(dir) {
  namespace fs = std::filesystem;
  const fs::path timeline = fs::path(dir) / "timeline.csv";
  const fs::path events = fs::path(dir) / "events.jsonl";
  std::error_code ec;
  const bool existed = fs::exists(timeline, ec) && fs::file_size(timeline, ec) > 0;
  if (existed) {
    std::ifstream in(timeline);
    std::string header;
    std::getline(in, header);
    if (header != kTimelineHeader) {
      throw Error(StatusCode::kFailedPrecondition,
                  timeline.string() + " is not a yamor-lifelong timeline (header \"" + header + "\")");
    }
  }
  timeline_.open(timeline, std::ios::app);
  if (!timeline_) throw Error(StatusCode::kUnavailable, "cannot write " + timeline.string());
  events_.open(events, std::ios::app);
  if (!events_) throw Error(StatusCode::kUnavailable, "cannot write " + events.string());
  if (!existed) timeline_ << kTimelineHeader << "\n" << std::flush;
}

void TimelineWriter::Row(const TimelineRow& row) { timeline_ << TimelineLine(row) << "\n" << std::flush; }

void TimelineWriter::Event(const LifeEvent& event) { events_ << EventLine(event) << "\n" << std::flush; }

FramingLog::FramingLog(LifeLog& inner, std::string dir, std::function<std::string()> take_frame,
                       std::vector<std::string> kinds)
    : inner_(inner), dir_(std::move(dir)), take_frame_(std::move(take_frame)),
      kinds_(std::move(kinds)) {}

void FramingLog::Event(const LifeEvent& event) {
  if (std::find(kinds_.begin(), kinds_.end(), event.kind) == kinds_.end() || !take_frame_) {
    inner_.Event(event);
    return;
  }
  LifeEvent framed = event;
  try {
    const std::string png = take_frame_();
    const int number = ++counts_[event.kind];
    const std::string name =
        "frames/" + event.kind + "-" + (number < 10 ? "0" : "") + std::to_string(number) + ".png";
    const std::filesystem::path path = std::filesystem::path(dir_) / name;
    std::filesystem::create_directories(path.parent_path());
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(png.data(), static_cast<std::streamsize>(png.size()));
    out.close();
    if (!out) throw Error(StatusCode::kUnavailable, "cannot write " + path.string());
    framed.fields.emplace_back("frame", JsonString(name));
    ++frames_;
  } catch (const std::exception& e) {
    if (failures_++ == 0) {
      Log().warn("no picture of the {} event (nor of later ones that fail alike): {}", event.kind,
                 e.what());
    }
  }
  inner_.Event(framed);
}

bool PlotTimeline(const std::string& dir, const std::string& title, const std::string& script,
                  const std::string& python) {
  if (script.empty()) {
    Log().warn("timeline.png not drawn: plot_timeline.py not found (set YAMOR_PLOT_DIR)");
    return false;
  }
  const std::string csv = (std::filesystem::path(dir) / "timeline.csv").string();
  const std::string png = (std::filesystem::path(dir) / "timeline.png").string();
  std::string error;
  const int status = optimizer::RunProgram({python, script, csv, png, "--title", title}, &error);
  if (status == 0) return true;
  if (status < 0) {
    Log().warn("timeline.png not drawn: {}", error);
  } else {
    Log().warn("timeline.png not drawn: {} {} exited with status {} (is matplotlib installed? "
               "pip install -r tools/requirements.txt)", python, script, status);
  }
  return false;
}

}  // namespace yamor::lifelong
