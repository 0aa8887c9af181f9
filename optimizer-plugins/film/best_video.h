// The video of an optimization's best gait (issue 14): the frames of a
// filmed evaluation (HostPool::FilmCandidate) become best.mp4 through the
// ffmpeg tool (a numbered PNG sequence and a note without it) and
// best-strip.png, six frames of one gait period side by side for reports.
#pragma once

#include <string>
#include <vector>

#include "cpg/robot_config.h"
#include "optimizer-plugins/framework/host_pool.h"
#include "physics/render/image.h"
#include "physics/render/video.h"

namespace yamor::optimizer {

/// Frames in best-strip.png.
inline constexpr int kStripFrames = 6;
/// White pixels between two frames of the strip.
inline constexpr int kStripGap = 4;

/// The gait period of `config` [s]: 1 / the master module's oscillator
/// frequency (every module of a locked CPG runs at it); 0 when the master
/// does not oscillate or is missing.
double GaitPeriod(const cpg::RobotConfig& config);

/// Indices into `times` (frame times, ascending) of `count` frames across
/// the last gait period: the frames nearest to t_last - period + (k+1) *
/// period / count, k = 0..count-1 (the last one is the last frame). When
/// `period` is 0 or longer than the frames span, the frames spread evenly
/// over the whole span instead. Empty for no frames.
std::vector<std::size_t> StripFrameIndices(const std::vector<double>& times, double period,
                                           int count = kStripFrames);

/// `images` side by side, `gap` white pixels between two, top-aligned on
/// a white background as tall as the tallest. Throws yamor::Error
/// (INVALID_ARGUMENT) for no images or an inconsistent one.
render::Image ComposeStrip(const std::vector<render::Image>& images, int gap = kStripGap);

/// What WriteBestVideo wrote.
struct BestVideo {
  bool video = false;       ///< True: `video_path` is a video made by ffmpeg.
  std::string video_path;   ///< best.mp4, or the first PNG of the sequence; empty when it failed.
  int frames = 0;           ///< Frames in the video or the sequence.
  std::string note;         ///< For the user: why there is no video and how to make one.
  std::string video_error;  ///< Why the video failed (then no best.mp4 is left).
  std::string strip_path;   ///< best-strip.png; empty when it failed.
  int strip_width = 0;      ///< Its size [px].
  int strip_height = 0;     ///< Its size [px].
  std::string strip_error;  ///< Why the strip failed.
};

/// Writes `dir`/best.mp4 (or best-000000.png, ... and a note when ffmpeg
/// cannot run) and `dir`/best-strip.png from `frames`. First removes what an
/// earlier run left (best.mp4, best-NNNNNN.png, best-strip.png). The video
/// and the strip fail separately: each failure is reported in the result
/// (and a partial best.mp4 removed), never thrown. Throws only
/// yamor::Error(INVALID_ARGUMENT) for no frames.
BestVideo WriteBestVideo(const std::vector<FilmFrame>& frames, double frame_rate,
                         double gait_period, const std::string& dir,
                         const render::VideoOptions& video_options = {});

/// As above for a filmed evaluation: with an MP4 the host made
/// (FilmOptions::mp4), best.mp4 is its bytes and best-strip.png is its PNG
/// frames side by side, in order (the client asked for the strip's frames);
/// without one (the host could not run ffmpeg), WriteBestVideo(film.frames,
/// ...). Throws only yamor::Error(INVALID_ARGUMENT) for a film with neither.
BestVideo WriteBestVideo(const FilmResult& film, double frame_rate, double gait_period,
                         const std::string& dir, const render::VideoOptions& video_options = {});

}  // namespace yamor::optimizer
