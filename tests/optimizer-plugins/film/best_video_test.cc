// The video of the best gait: which frames make the strip, how they are
// laid out, and WriteBestVideo with ffmpeg, without it and with a failing one.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <span>
#include <string>
#include <vector>

#include "common/status.h"
#include "optimizer-plugins/film/best_video.h"

namespace yamor::optimizer {
namespace {

namespace fs = std::filesystem;

// A frame of one colour (a distinct grey per index), as PNG bytes.
FilmFrame Frame(int index, double time, int width = 20, int height = 10) {
  render::Image image{.width = width, .height = height};
  image.rgba.assign(static_cast<std::size_t>(width) * height * 4, 255);
  for (std::size_t i = 0; i < image.rgba.size(); i += 4) {
    image.rgba[i] = image.rgba[i + 1] = image.rgba[i + 2] = static_cast<uint8_t>(index);
  }
  const std::vector<uint8_t> png = render::EncodePng(image);
  return FilmFrame{.time = time, .png = std::string(png.begin(), png.end())};
}

std::vector<FilmFrame> Frames(int count, double rate) {
  std::vector<FilmFrame> out;
  for (int i = 0; i < count; ++i) out.push_back(Frame(i, i / rate));
  return out;
}

render::Image Read(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  const std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), {});
  return render::DecodePng(bytes);
}

class TempDir {
 public:
  TempDir() {
    char name[] = "/tmp/yamor-film-test-XXXXXX";
    path_ = mkdtemp(name);
  }
  ~TempDir() { fs::remove_all(path_); }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

TEST(BestVideoTest, GaitPeriodIsTheMastersOscillatorPeriod) {
  cpg::RobotConfig config;
  config.master_id = 4;
  config.modules = {{.id = 3, .speed = 2.0}, {.id = 4, .speed = 0.5}};
  EXPECT_DOUBLE_EQ(GaitPeriod(config), 2.0);
  config.modules[1].speed = 0.0;
  EXPECT_EQ(GaitPeriod(config), 0.0);
  config.master_id = 9;
  EXPECT_EQ(GaitPeriod(config), 0.0);
}

TEST(BestVideoTest, StripFramesSpanTheLastGaitPeriodOrTheWholeFilm) {
  std::vector<double> times;
  for (int i = 0; i < 75; ++i) times.push_back(i / 25.0);  // 0 .. 2.96 s
  // One 1.2-s period ending at the last frame: every 0.2 s from 1.96 s.
  EXPECT_EQ(StripFrameIndices(times, 1.2), (std::vector<std::size_t>{49, 54, 59, 64, 69, 74}));
  // No period, or a period longer than the film: evenly over the film.
  const std::vector<std::size_t> spread{0, 15, 30, 44, 59, 74};
  EXPECT_EQ(StripFrameIndices(times, 0.0), spread);
  EXPECT_EQ(StripFrameIndices(times, 3.5), spread);
  EXPECT_EQ(StripFrameIndices({0.0}, 1.0), std::vector<std::size_t>(6, 0));
  EXPECT_TRUE(StripFrameIndices({}, 1.0).empty());
}

TEST(BestVideoTest, ComposeStripPutsImagesSideBySideWithWhiteGaps) {
  std::vector<render::Image> images;
  for (int i = 0; i < 3; ++i) {
    const FilmFrame f = Frame(10 * (i + 1), 0.0, 5, i == 1 ? 6 : 4);
    images.push_back(render::DecodePng(std::span(
        reinterpret_cast<const uint8_t*>(f.png.data()), f.png.size())));
  }
  const render::Image strip = ComposeStrip(images, 2);
  EXPECT_EQ(strip.width, 3 * 5 + 2 * 2);
  EXPECT_EQ(strip.height, 6);
  EXPECT_EQ(strip.At(0, 0)[0], 10);
  EXPECT_EQ(strip.At(5, 0)[0], 255) << "gap";
  EXPECT_EQ(strip.At(7, 5)[0], 20) << "the taller image, bottom row";
  EXPECT_EQ(strip.At(14, 0)[0], 30);
  EXPECT_EQ(strip.At(14, 5)[0], 255) << "below the shorter image";
  EXPECT_THROW(ComposeStrip({}), Error);
}

TEST(BestVideoTest, WithoutFfmpegAPngSequenceAndANote) {
  TempDir dir;
  std::ofstream(dir.path() / "best-000099.png") << "from an earlier run";
  const BestVideo video = WriteBestVideo(Frames(30, 25.0), 25.0, 0.4, dir.path().string(),
                                         render::VideoOptions{.ffmpeg = "/nonexistent/ffmpeg"});
  EXPECT_FALSE(video.video);
  EXPECT_EQ(video.frames, 30);
  EXPECT_TRUE(video.video_error.empty()) << video.video_error;
  EXPECT_NE(video.note.find("cannot run /nonexistent/ffmpeg"), std::string::npos) << video.note;
  EXPECT_TRUE(fs::exists(dir.path() / "best-000029.png"));
  EXPECT_FALSE(fs::exists(dir.path() / "best-000030.png"));
  EXPECT_FALSE(fs::exists(dir.path() / "best-000099.png")) << "the old sequence is removed";
  EXPECT_FALSE(fs::exists(dir.path() / "best.mp4"));
  // The strip: the last 0.4 s, every 1/15 s up to the last frame (1.16 s):
  // frames 21, 22, 24, 26, 27, 29.
  const render::Image strip = Read(dir.path() / "best-strip.png");
  EXPECT_EQ(strip.width, 6 * 20 + 5 * kStripGap);
  EXPECT_EQ(strip.height, 10);
  EXPECT_EQ(video.strip_width, strip.width);
  EXPECT_EQ(strip.At(0, 0)[0], 21);
  EXPECT_EQ(strip.At(3 * (20 + kStripGap), 0)[0], 26);
  EXPECT_EQ(strip.At(strip.width - 1, 9)[0], 29);
}

TEST(BestVideoTest, AFailingFfmpegLeavesNoVideoButTheStrip) {
  TempDir dir;
  const BestVideo video = WriteBestVideo(Frames(10, 25.0), 25.0, 0.0, dir.path().string(),
                                         render::VideoOptions{.ffmpeg = "false"});
  EXPECT_FALSE(video.video_error.empty());
  EXPECT_TRUE(video.video_path.empty());
  EXPECT_FALSE(fs::exists(dir.path() / "best.mp4"));
  EXPECT_TRUE(video.strip_error.empty()) << video.strip_error;
  EXPECT_TRUE(fs::exists(dir.path() / "best-strip.png"));
  EXPECT_THROW(WriteBestVideo(std::vector<FilmFrame>{}, 25.0, 0.0, dir.path().string()), Error);
}

TEST(BestVideoTest, WithFfmpegAnMp4) {
  if (std::system("ffmpeg -version > /dev/null 2>&1") != 0) GTEST_SKIP() << "ffmpeg not installed";
  TempDir dir;
  const BestVideo video = WriteBestVideo(Frames(12, 25.0), 25.0, 0.0, dir.path().string());
  ASSERT_TRUE(video.video_error.empty()) << video.video_error;
  EXPECT_TRUE(video.video);
  EXPECT_EQ(video.frames, 12);
  EXPECT_EQ(video.video_path, (dir.path() / "best.mp4").string());
  EXPECT_GT(fs::file_size(dir.path() / "best.mp4"), 100u);
}

}  // namespace
}  // namespace yamor::optimizer
