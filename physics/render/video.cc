#include "physics/render/video.h"

#include <fcntl.h>
#include <csignal>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include <fmt/format.h>

#include "common/status.h"
#include "physics/render/renderer.h"

extern char** environ;

namespace yamor::render {
namespace {

namespace fs = std::filesystem;

bool EndsWith(const std::string& text, const std::string& suffix) {
  return text.size() >= suffix.size() &&
         text.compare(text.size() - suffix.size(), suffix.size(), suffix) == 0;
}

std::string FormatRate(double rate) { return fmt::format("{}", rate); }

}  // namespace

VideoWriter::VideoWriter(std::string path, VideoOptions options)
    : path_(std::move(path)), options_(std::move(options)) {
  if (path_.empty()) throw Error(StatusCode::kInvalidArgument, "video path is empty");
  if (!(options_.frame_rate > 0.0 && options_.frame_rate <= 1000.0)) {
    throw Error(StatusCode::kOutOfRange,
                fmt::format("video frame rate {} is outside (0, 1000]", options_.frame_rate));
  }
  if (options_.ffmpeg.empty()) {
    const char* env = std::getenv("YAMOR_FFMPEG");
    options_.ffmpeg = env && *env ? env : "ffmpeg";
  }
  const bool raw = options_.raw_width > 0 || options_.raw_height > 0;
  if (raw) ValidateFrameSize(options_.raw_width, options_.raw_height);
  std::signal(SIGPIPE, SIG_IGN);

  std::vector<std::string> argv = {options_.ffmpeg, "-hide_banner", "-loglevel", "error", "-y"};
  if (raw) {
    for (const std::string& a :
         {std::string("-f"), std::string("rawvideo"), std::string("-pix_fmt"), std::string("rgba"),
          std::string("-s"), fmt::format("{}x{}", options_.raw_width, options_.raw_height),
          std::string("-framerate"), FormatRate(options_.frame_rate), std::string("-i"),
          std::string("-")}) {
      argv.push_back(a);
    }
  } else {
    for (const std::string& a : {std::string("-f"), std::string("image2pipe"),
                                 std::string("-framerate"), FormatRate(options_.frame_rate),
                                 std::string("-c:v"), std::string("png"), std::string("-i"),
                                 std::string("-")}) {
      argv.push_back(a);
    }
  }
  if (EndsWith(path_, ".mp4") || EndsWith(path_, ".mov") || EndsWith(path_, ".mkv")) {
    // H.264 in 4:2:0 wants even sizes: an odd width or height gets one
    // more column or row. One encoder thread: small frames gain nothing
    // from x264's frame threads but pay for their synchronisation (and the
    // CPU is better spent on other evaluations).
    for (const char* a : {"-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-c:v", "libx264", "-preset",
                          "ultrafast", "-crf", "20", "-pix_fmt", "yuv420p", "-threads", "1"}) {
      argv.emplace_back(a);
    }
    if (EndsWith(path_, ".mp4")) {
      argv.emplace_back("-movflags");
      argv.emplace_back("+faststart");
    }
  }
  argv.push_back(path_);

  char log_template[] = "/tmp/yamor-ffmpeg-XXXXXX";
  const int log_fd = mkstemp(log_template);
  if (log_fd >= 0) {
    log_path_ = log_template;
    close(log_fd);
  }
  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0) {
    throw Error(StatusCode::kInternal, std::string("pipe for ffmpeg: ") + std::strerror(errno));
  }
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, fds[0], STDIN_FILENO);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&actions, STDERR_FILENO,
                                   log_path_.empty() ? "/dev/null" : log_path_.c_str(),
                                   O_WRONLY | O_TRUNC, 0);
  std::vector<char*> args;
  for (std::string& a : argv) args.push_back(a.data());
  args.push_back(nullptr);
  const int spawned = posix_spawnp(&pid_, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  close(fds[0]);
  if (spawned != 0) {
    close(fds[1]);
    pid_ = -1;
    const fs::path p(path_);
    sequence_stem_ = (p.parent_path() / p.stem()).string();
    result_.pattern = sequence_stem_ + "-%06d.png";
    result_.note = fmt::format("cannot run {} ({}): wrote a numbered PNG sequence instead; make "
                               "the video with: ffmpeg -framerate {} -i {} -pix_fmt yuv420p {}",
                               options_.ffmpeg, std::strerror(spawned),
                               FormatRate(options_.frame_rate), result_.pattern, path_);
  } else {
    pipe_ = fds[1];
    result_.video = true;
    result_.path = path_;
  }
}

VideoWriter::~VideoWriter() {
  if (!finished_) Stop();
  if (!log_path_.empty()) std::remove(log_path_.c_str());
}

void VideoWriter::Stop() {
  if (pipe_ >= 0) {
    close(pipe_);
    pipe_ = -1;
  }
  if (pid_ > 0) {
    int status = 0;
    while (waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
    }
    pid_ = -1;
  }
}

std::string VideoWriter::FfmpegMessages() const {
  std::ifstream in(log_path_);
  std::ostringstream text;
  text << in.rdbuf();
  std::string s = text.str();
  while (!s.empty() && (s.back() == '\n' || s.back() == '\r')) s.pop_back();
  return s.empty() ? std::string("no message") : s;
}

void VideoWriter::WriteSequenceFile(std::span<const uint8_t> png) {
  const std::string name = fmt::format("{}-{:06d}.png", sequence_stem_, result_.frames);
  std::ofstream out(name, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
  out.close();
  if (!out) throw Error(StatusCode::kInternal, "cannot write " + name);
  if (result_.frames == 0) result_.path = name;
  ++result_.frames;
}

void VideoWriter::AddFrame(std::span<const uint8_t> png) {
  YAMOR_CHECK(!finished_, "VideoWriter::AddFrame after Finish");
  if (options_.raw_width > 0) {
    throw Error(StatusCode::kFailedPrecondition,
                "this video takes raw images (AddImage), not PNG frames");
  }
  if (!result_.video) {
    WriteSequenceFile(png);
    return;
  }
  WriteToFfmpeg(png.data(), png.size());
  ++result_.frames;
}

void VideoWriter::AddImage(const Image& image) {
  YAMOR_CHECK(!finished_, "VideoWriter::AddImage after Finish");
  if (options_.raw_width <= 0) {
    throw Error(StatusCode::kFailedPrecondition,
                "this video takes PNG frames (AddFrame); set raw_width and raw_height for images");
  }
  if (image.width != options_.raw_width || image.height != options_.raw_height ||
      image.rgba.size() != static_cast<std::size_t>(image.width) * image.height * 4) {
    throw Error(StatusCode::kInvalidArgument,
                fmt::format("video frame {}x{} ({} bytes) is not the video's {}x{} RGBA",
                            image.width, image.height, image.rgba.size(), options_.raw_width,
                            options_.raw_height));
  }
  if (!result_.video) {
    WriteSequenceFile(EncodePng(image));
    return;
  }
  WriteToFfmpeg(image.rgba.data(), image.rgba.size());
  ++result_.frames;
}

void VideoWriter::WriteToFfmpeg(const uint8_t* data, std::size_t size) {
  std::size_t done = 0;
  while (done < size) {
    const ssize_t n = write(pipe_, data + done, size - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int error = errno;
      Stop();
      finished_ = true;
      throw Error(StatusCode::kUnavailable,
                  fmt::format("{} stopped taking frames ({}): {}", options_.ffmpeg,
                              std::strerror(error), FfmpegMessages()));
    }
    done += static_cast<std::size_t>(n);
  }
}

VideoResult VideoWriter::Finish() {
  YAMOR_CHECK(!finished_, "VideoWriter::Finish called twice");
  finished_ = true;
  if (!result_.video) return result_;
  close(pipe_);
  pipe_ = -1;
  int status = 0;
  while (waitpid(pid_, &status, 0) < 0) {
    if (errno != EINTR) break;
  }
  pid_ = -1;
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    throw Error(StatusCode::kUnavailable,
                fmt::format("{} failed to write {} (status {}): {}", options_.ffmpeg, path_,
                            WIFEXITED(status) ? WEXITSTATUS(status) : -1, FfmpegMessages()));
  }
  return result_;
}

}  // namespace yamor::render
