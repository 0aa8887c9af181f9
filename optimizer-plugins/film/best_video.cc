#include "optimizer-plugins/film/best_video.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <regex>
#include <span>
#include <system_error>

#include "common/status.h"

namespace yamor::optimizer {
namespace {

namespace fs = std::filesystem;

std::span<const uint8_t> Bytes(const std::string& png) {
  return {reinterpret_cast<const uint8_t*>(png.data()), png.size()};
}

// Removes what an earlier run left in `dir`: best.mp4, best-NNNNNN.png, best-strip.png.
void RemoveOldVideo(const fs::path& dir) {
  std::error_code ec;
  fs::remove(dir / "best.mp4", ec);
  fs::remove(dir / "best-strip.png", ec);
  const std::regex sequence(R"(best-[0-9]{6}\.png)");
  for (const fs::directory_entry& entry : fs::directory_iterator(dir, ec)) {
    if (std::regex_match(entry.path().filename().string(), sequence)) fs::remove(entry.path(), ec);
  }
}

void WriteFile(const fs::path& path, std::span<const uint8_t> bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  out.close();
  if (!out) throw Error(StatusCode::kInternal, "cannot write " + path.string());
}

// `frames` side by side as `dir`/best-strip.png; a failure goes to out.strip_error.
void WriteStrip(const std::vector<const FilmFrame*>& frames, const fs::path& dir, BestVideo& out) {
  try {
    std::vector<render::Image> images;
    for (const FilmFrame* frame : frames) images.push_back(render::DecodePng(Bytes(frame->png)));
    const render::Image strip = ComposeStrip(images);
    const fs::path strip_path = dir / "best-strip.png";
    WriteFile(strip_path, render::EncodePng(strip));
    out.strip_path = strip_path.string();
    out.strip_width = strip.width;
    out.strip_height = strip.height;
  } catch (const std::exception& e) {
    out.strip_error = e.what();
  }
}

}  // namespace

double GaitPeriod(const cpg::RobotConfig& config) {
  const cpg::ModuleParams* master = config.FindModule(config.master_id);
  if (master == nullptr || !(master->speed > 0.0) || !std::isfinite(master->speed)) return 0.0;
  return 1.0 / master->speed;
}

std::vector<std::size_t> StripFrameIndices(const std::vector<double>& times, double period,
                                           int count) {
  std::vector<std::size_t> out;
  if (times.empty() || count <= 0) return out;
  const double first = times.front();
  const double last = times.back();
  const bool one_period = period > 0.0 && period <= last - first;
  for (int k = 0; k < count; ++k) {
    const double target =
        one_period ? last - period + (k + 1) * period / count
                   : (count == 1 ? last : first + (last - first) * k / (count - 1));
    // The nearest frame time (the earlier one on a tie).
    const auto it = std::lower_bound(times.begin(), times.end(), target);
    std::size_t index = static_cast<std::size_t>(it - times.begin());
    if (index == times.size()) {
      index = times.size() - 1;
    } else if (index > 0 && target - times[index - 1] <= times[index] - target) {
      --index;
    }
    out.push_back(index);
  }
  return out;
}

render::Image ComposeStrip(const std::vector<render::Image>& images, int gap) {
  if (images.empty()) throw Error(StatusCode::kInvalidArgument, "a strip needs an image");
  if (gap < 0) throw Error(StatusCode::kInvalidArgument, "strip gap " + std::to_string(gap) + " < 0");
  render::Image strip;
  for (const render::Image& image : images) {
    if (image.width <= 0 || image.height <= 0 ||
        image.rgba.size() != static_cast<std::size_t>(image.width) * image.height * 4) {
      throw Error(StatusCode::kInvalidArgument,
                  "strip image " + std::to_string(image.width) + "x" + std::to_string(image.height) +
                      " holds " + std::to_string(image.rgba.size()) + " bytes");
    }
    strip.width += image.width;
    strip.height = std::max(strip.height, image.height);
  }
  strip.width += gap * static_cast<int>(images.size() - 1);
  strip.rgba.assign(static_cast<std::size_t>(strip.width) * strip.height * 4, 255);
  int x0 = 0;
  for (const render::Image& image : images) {
    const std::size_t row_bytes = static_cast<std::size_t>(image.width) * 4;
    for (int y = 0; y < image.height; ++y) {
      std::memcpy(&strip.rgba[(static_cast<std::size_t>(y) * strip.width + x0) * 4],
                  &image.rgba[static_cast<std::size_t>(y) * row_bytes], row_bytes);
    }
    x0 += image.width + gap;
  }
  return strip;
}

BestVideo WriteBestVideo(const std::vector<FilmFrame>& frames, double frame_rate,
                         double gait_period, const std::string& dir,
                         const render::VideoOptions& video_options) {
  if (frames.empty()) throw Error(StatusCode::kInvalidArgument, "no frames to make a video of");
  const fs::path folder(dir);
  RemoveOldVideo(folder);
  BestVideo out;

  const fs::path video_path = folder / "best.mp4";
  try {
    render::VideoOptions options = video_options;
    options.frame_rate = frame_rate;
    render::VideoWriter writer(video_path.string(), options);
    for (const FilmFrame& frame : frames) writer.AddFrame(Bytes(frame.png));
    const render::VideoResult result = writer.Finish();
    out.video = result.video;
    out.video_path = result.path;
    out.frames = result.frames;
    out.note = result.note;
  } catch (const std::exception& e) {
    out.video_error = e.what();
    out.video_path.clear();
    std::error_code ec;
    fs::remove(video_path, ec);  // never leave a partial video behind
  }

  std::vector<double> times;
  times.reserve(frames.size());
  for (const FilmFrame& frame : frames) times.push_back(frame.time);
  std::vector<const FilmFrame*> strip_frames;
  for (std::size_t index : StripFrameIndices(times, gait_period)) {
    strip_frames.push_back(&frames[index]);
  }
  WriteStrip(strip_frames, folder, out);
  return out;
}

BestVideo WriteBestVideo(const FilmResult& film, double frame_rate, double gait_period,
                         const std::string& dir, const render::VideoOptions& video_options) {
  if (film.mp4.empty()) {
    BestVideo out = WriteBestVideo(film.frames, frame_rate, gait_period, dir, video_options);
    if (out.note.empty()) out.note = film.video_note;
    return out;
  }
  const fs::path folder(dir);
  RemoveOldVideo(folder);
  BestVideo out;
  const fs::path video_path = folder / "best.mp4";
  try {
    // Whole or not at all: a partial best.mp4 is never left behind.
    const fs::path partial = folder / "best.mp4.partial";
    WriteFile(partial, Bytes(film.mp4));
    fs::rename(partial, video_path);
    out.video = true;
    out.video_path = video_path.string();
    out.frames = film.mp4_frames;
  } catch (const std::exception& e) {
    out.video_error = e.what();
    std::error_code ec;
    fs::remove(folder / "best.mp4.partial", ec);
  }
  std::vector<const FilmFrame*> strip_frames;
  for (const FilmFrame& frame : film.frames) strip_frames.push_back(&frame);
  WriteStrip(strip_frames, folder, out);
  return out;
}

}  // namespace yamor::optimizer
