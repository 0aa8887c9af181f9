#include "physics/render/video.h"

#include <fcntl.h>
#include <csignal>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
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

// BT.601 limited range in fixed point (the formulas' coefficients / 255 x
// 2^16, rounded): the luma of one pixel, and Cb/Cr from the sums of 4
// pixels' channels. The Cb and Cr coefficients sum to 0: greys stay grey.
inline uint8_t Luma(int r, int g, int b) {
  return static_cast<uint8_t>(((16829 * r + 33039 * g + 6416 * b + 32768) >> 16) + 16);
}
inline uint8_t Luma(const uint8_t* p) { return Luma(p[0], p[1], p[2]); }
inline uint8_t Cb(int r4, int g4, int b4) {
  return static_cast<uint8_t>(((-9714 * r4 - 19070 * g4 + 28784 * b4 + 131072) >> 18) + 128);
}
inline uint8_t Cr(int r4, int g4, int b4) {
  return static_cast<uint8_t>(((28784 * r4 - 24103 * g4 - 4681 * b4 + 131072) >> 18) + 128);
}

int Even(int n) { return n + (n & 1); }

// The RGBA pixel at `p` as one 32-bit word, red in the low byte whatever the
// machine's byte order.
inline uint32_t Word(const uint8_t* p) {
  uint32_t word;
  std::memcpy(&word, p, 4);
  if constexpr (std::endian::native == std::endian::big) word = __builtin_bswap32(word);
  return word;
}

// On x86-64, the loops below are also compiled for AVX2 and the better one is
// chosen when the program loads: SSE2 has no 32-bit vector multiply (the
// compiler builds each product from 16-bit ones), and the conversion cost
// 0.26-0.31 ms a 320x240 frame against 0.06-0.09 ms with AVX2 (docs/benchmarks.md, "Rendering", third
// round). Integer arithmetic: both give the same bytes. Not under
// ThreadSanitizer: the clone's resolver runs while the dynamic loader relocates
// the program, before TSan's runtime is set up, and its instrumented code
// crashed every binary that links yamor_render at start.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(__SANITIZE_THREAD__)
#define YAMOR_VECTOR_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define YAMOR_VECTOR_CLONES
#endif

// Luma of every pixel of a w x h image, and chroma of its whole 2x2 blocks,
// with each pixel loaded as one word (contiguous loads the compiler
// vectorises; byte-wise loads with a stride of 4 it did not do well). The
// sums of a block's red and blue are formed in one word's two halves (at
// most 4 x 255 each: no carry between them).
YAMOR_VECTOR_CLONES void ConvertPixels(const uint8_t* pixels, int w, int h, int ew,
                                       uint8_t* y_plane, uint8_t* cb_plane, uint8_t* cr_plane) {
  const std::size_t stride = static_cast<std::size_t>(w) * 4;
  for (int y = 0; y < h; ++y) {
    const uint8_t* row = pixels + y * stride;
    uint8_t* out = y_plane + static_cast<std::size_t>(y) * ew;
    for (int x = 0; x < w; ++x) {
      const uint32_t p = Word(row + 4 * x);
      out[x] = Luma(static_cast<int>(p & 0xffu), static_cast<int>((p >> 8) & 0xffu),
                    static_cast<int>((p >> 16) & 0xffu));
    }
  }
  const int full_w = w / 2;
  for (int y = 0; y + 1 < h; y += 2) {
    const uint8_t* r0 = pixels + y * stride;
    const uint8_t* r1 = r0 + stride;
    uint8_t* cb = cb_plane + static_cast<std::size_t>(y / 2) * (ew / 2);
    uint8_t* cr = cr_plane + static_cast<std::size_t>(y / 2) * (ew / 2);
    for (int i = 0; i < full_w; ++i) {
      const int x = 8 * i;
      const uint32_t a = Word(r0 + x);
      const uint32_t b = Word(r0 + x + 4);
      const uint32_t c = Word(r1 + x);
      const uint32_t d = Word(r1 + x + 4);
      const uint32_t rb = (a & 0xff00ffu) + (b & 0xff00ffu) + (c & 0xff00ffu) + (d & 0xff00ffu);
      const uint32_t g4 = ((a >> 8) & 0xffu) + ((b >> 8) & 0xffu) + ((c >> 8) & 0xffu) +
                          ((d >> 8) & 0xffu);
      const int r4 = static_cast<int>(rb & 0xffffu);
      const int b4 = static_cast<int>(rb >> 16);
      cb[i] = Cb(r4, static_cast<int>(g4), b4);
      cr[i] = Cr(r4, static_cast<int>(g4), b4);
    }
  }
}

}  // namespace

void RgbaToYuv420(const Image& image, std::vector<uint8_t>& yuv) {
  const int w = image.width;
  const int h = image.height;
  if (w < 1 || h < 1 || image.rgba.size() != static_cast<std::size_t>(w) * h * 4) {
    throw Error(StatusCode::kInvalidArgument,
                fmt::format("RgbaToYuv420: image {}x{} has {} bytes, not width x height x 4", w, h,
                            image.rgba.size()));
  }
  const int ew = Even(w);
  const int eh = Even(h);
  const std::size_t luma = static_cast<std::size_t>(ew) * eh;
  const std::size_t chroma = luma / 4;
  yuv.resize(luma + 2 * chroma);
  uint8_t* y_plane = yuv.data();
  uint8_t* cb_plane = y_plane + luma;
  uint8_t* cr_plane = cb_plane + chroma;
  const uint8_t* pixels = image.rgba.data();
  const std::size_t stride = static_cast<std::size_t>(w) * 4;
  // Two plain passes over the pixels (luma, then chroma of whole 2x2
  // blocks) that the compiler vectorises, padding (odd sizes) apart: the
  // per-block loop with its padding checks was not vectorised.
  ConvertPixels(pixels, w, h, ew, y_plane, cb_plane, cr_plane);
  // Padding (odd sizes) is black, as ffmpeg's pad filter made it.
  static constexpr uint8_t kBlack[4] = {0, 0, 0, 0};
  if (ew != w) {
    for (int y = 0; y < h; ++y) y_plane[static_cast<std::size_t>(y) * ew + w] = Luma(kBlack);
  }
  if (eh != h) std::fill_n(y_plane + static_cast<std::size_t>(h) * ew, ew, Luma(kBlack));
  const int full_w = w / 2;  // chroma columns of whole 2x2 blocks
  for (int y = 0; y < eh; y += 2) {
    const uint8_t* r0 = pixels + y * stride;
    uint8_t* cb = cb_plane + static_cast<std::size_t>(y / 2) * (ew / 2);
    uint8_t* cr = cr_plane + static_cast<std::size_t>(y / 2) * (ew / 2);
    // The blocks that take padding: the last column of an odd width, every
    // block of the last row of an odd height.
    for (int i = y + 1 < h ? full_w : 0; i < ew / 2; ++i) {
      const int x = 2 * i;
      const uint8_t* a = r0 + x * 4;
      const uint8_t* b = x + 1 < w ? a + 4 : kBlack;
      const uint8_t* c = y + 1 < h ? a + stride : kBlack;
      const uint8_t* d = (x + 1 < w && y + 1 < h) ? a + stride + 4 : kBlack;
      const int r4 = a[0] + b[0] + c[0] + d[0];
      const int g4 = a[1] + b[1] + c[1] + d[1];
      const int b4 = a[2] + b[2] + c[2] + d[2];
      cb[i] = Cb(r4, g4, b4);
      cr[i] = Cr(r4, g4, b4);
    }
  }
}

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
    // Already 4:2:0 at even sizes (RgbaToYuv420): ffmpeg converts nothing.
    for (const std::string& a :
         {std::string("-f"), std::string("rawvideo"), std::string("-pix_fmt"),
          std::string("yuv420p"), std::string("-s"),
          fmt::format("{}x{}", Even(options_.raw_width), Even(options_.raw_height)),
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
    // more column or row (raw frames come padded). One encoder thread: small
    // frames gain nothing from x264's frame threads but pay for their
    // synchronisation (and the CPU is better spent on other evaluations).
    if (!raw) {
      for (const char* a : {"-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-pix_fmt", "yuv420p"}) {
        argv.emplace_back(a);
      }
    }
    for (const char* a :
         {"-c:v", "libx264", "-preset", "ultrafast", "-crf", "20", "-threads", "1"}) {
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
  // ffmpeg starts with no signal blocked and SIGPIPE at its default, whatever
  // this process does (yamord blocks SIGINT/SIGTERM in every thread to wait
  // for them; VideoWriter ignores SIGPIPE).
  posix_spawnattr_t attributes;
  posix_spawnattr_init(&attributes);
  sigset_t no_signals;
  sigemptyset(&no_signals);
  posix_spawnattr_setsigmask(&attributes, &no_signals);
  sigset_t pipe_signal;
  sigemptyset(&pipe_signal);
  sigaddset(&pipe_signal, SIGPIPE);
  posix_spawnattr_setsigdefault(&attributes, &pipe_signal);
  posix_spawnattr_setflags(&attributes, POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);
  const int spawned = posix_spawnp(&pid_, args[0], &actions, &attributes, args.data(), environ);
  posix_spawnattr_destroy(&attributes);
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
    // A raw frame is 115 KiB at 320x240: a pipe that holds several frames
    // saves ffmpeg and this process a wake-up every 64 KiB (best effort:
    // the system may cap the size).
    fcntl(pipe_, F_SETPIPE_SZ, 1 << 20);
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
  RgbaToYuv420(image, yuv_);
  WriteToFfmpeg(yuv_.data(), yuv_.size());
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
