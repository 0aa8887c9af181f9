// Videos from rendered frames: PNG frames, or RGBA images converted here to
// YUV 4:2:0, piped into the `ffmpeg` command-line tool (H.264 in an MP4 for
// *.mp4), or, on a machine without ffmpeg, a numbered PNG sequence next to
// the requested file.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <sys/types.h>
#include <vector>

#include "physics/render/image.h"

namespace yamor::render {

/// Settings of a VideoWriter. Thread-safety: plain value.
struct VideoOptions {
  double frame_rate = 25.0;  ///< Frames per second of the video, (0, 1000].
  /// The ffmpeg program (looked up in PATH); empty: $YAMOR_FFMPEG, else "ffmpeg".
  std::string ffmpeg;
  /// Both > 0: frames come as RGBA images of this size (AddImage) and go to
  /// ffmpeg raw, converted here to YUV 4:2:0 (RgbaToYuv420; `-f rawvideo
  /// -pix_fmt yuv420p`), with no PNG encoded or decoded and no colour
  /// conversion in ffmpeg on the way: for frames rendered in the writing
  /// process. Without ffmpeg, AddImage writes the PNG sequence itself.
  /// 0: frames come as PNG bytes (AddFrame).
  int raw_width = 0;
  int raw_height = 0;  ///< See raw_width.
};

/// Converts an opaque RGBA image to planar YUV 4:2:0 (ffmpeg's yuv420p) in
/// `yuv`: BT.601 limited range (Y 16..235, Cb/Cr 16..240, what players assume
/// for video without colour tags), Y = 16 + (65.481 R + 128.553 G + 24.966 B)
/// / 255 and so on, in fixed point (within half a step of the formulas);
/// each Cb/Cr sample from the mean of a 2x2 block. Odd sizes are padded to
/// even with black (as H.264 4:2:0 wants). `yuv` holds W·H luma bytes, then
/// W/2·H/2 Cb, then Cr, W and H the even sizes. Alpha is ignored. Throws
/// yamor::Error(INVALID_ARGUMENT) for an inconsistent image.
void RgbaToYuv420(const Image& image, std::vector<uint8_t>& yuv);

/// What a VideoWriter produced.
struct VideoResult {
  bool video = false;      ///< True: `path` is a video made by ffmpeg.
  std::string path;        ///< The video, or the first PNG of the sequence.
  std::string pattern;     ///< The sequence's printf pattern ("out-%06d.png"), when no video.
  int frames = 0;          ///< Frames written.
  std::string note;        ///< For the user, e.g. why there is no video and how to make one.
};

/// Writes one video. Starts ffmpeg when constructed; when ffmpeg cannot be
/// started (not installed) it writes `STEM-000000.png`, `STEM-000001.png`, ...
/// beside `path` instead and says so in the result's note. Ignores SIGPIPE
/// for the process (a failing ffmpeg then reports its error instead of
/// killing the caller).
///
/// Thread-safety: not thread-safe; one thread at a time.
class VideoWriter {
 public:
  /// Throws yamor::Error: OUT_OF_RANGE for a bad frame rate, INVALID_ARGUMENT
  /// for an empty path.
  VideoWriter(std::string path, VideoOptions options = {});
  /// Stops ffmpeg if Finish() was not called (the file may be incomplete).
  ~VideoWriter();
  VideoWriter(const VideoWriter&) = delete;
  VideoWriter& operator=(const VideoWriter&) = delete;

  /// Appends one frame (PNG bytes, every frame the same size). Throws
  /// yamor::Error(UNAVAILABLE) when ffmpeg stopped taking frames (with its
  /// message) or INTERNAL when a PNG file cannot be written.
  void AddFrame(std::span<const uint8_t> png);
  /// Appends one frame as an RGBA image (raw mode only: raw_width and
  /// raw_height set). Throws yamor::Error: INVALID_ARGUMENT for an image of
  /// another size, FAILED_PRECONDITION outside raw mode, and AddFrame's.
  void AddImage(const Image& image);
  /// Closes the video and waits for ffmpeg. Throws yamor::Error(UNAVAILABLE)
  /// with ffmpeg's messages when it failed.
  VideoResult Finish();
  /// True while frames go to ffmpeg; false when it could not be started
  /// (frames then become the PNG sequence) or after Finish.
  bool ToFfmpeg() const { return pipe_ >= 0; }

 private:
  std::string FfmpegMessages() const;
  void Stop();
  void WriteToFfmpeg(const uint8_t* data, std::size_t size);
  void WriteSequenceFile(std::span<const uint8_t> png);

  std::string path_;
  VideoOptions options_;
  pid_t pid_ = -1;
  int pipe_ = -1;           // ffmpeg's stdin
  std::string log_path_;    // ffmpeg's stderr
  std::string sequence_stem_;  // "dir/out" of dir/out-000000.png (no ffmpeg)
  std::vector<uint8_t> yuv_;   // raw mode: the frame being piped
  bool finished_ = false;
  VideoResult result_;
};

}  // namespace yamor::render
