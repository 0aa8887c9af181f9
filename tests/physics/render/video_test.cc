// VideoWriter: an MP4 through the ffmpeg tool (ffprobe checks it), and the
// numbered PNG sequence when ffmpeg is missing.
#include "physics/render/video.h"

#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>

#include "common/status.h"
#include "physics/render/image.h"

namespace yamor::render {
namespace {

namespace fs = std::filesystem;

std::vector<uint8_t> Frame(int width, int height, int shade) {
  Image image{.width = width, .height = height};
  image.rgba.assign(static_cast<std::size_t>(width) * height * 4, 255);
  for (std::size_t i = 0; i < image.rgba.size(); i += 4) image.rgba[i] = static_cast<uint8_t>(shade);
  return EncodePng(image, true);
}

std::string Shell(const std::string& command) {
  std::array<char, 256> buffer{};
  std::string out;
  std::unique_ptr<FILE, int (*)(FILE*)> pipe(popen(command.c_str(), "r"), pclose);
  if (!pipe) return out;
  while (fgets(buffer.data(), buffer.size(), pipe.get())) out += buffer.data();
  return out;
}

bool HaveFfmpeg() { return std::system("ffmpeg -version >/dev/null 2>&1") == 0; }

class VideoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("yamor_video_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(VideoTest, Mp4HasTheFrameCountAndSize) {
  if (!HaveFfmpeg()) GTEST_SKIP() << "ffmpeg is not installed";
  const std::string path = (dir_ / "clip.mp4").string();
  VideoWriter writer(path, VideoOptions{.frame_rate = 10});
  for (int i = 0; i < 12; ++i) writer.AddFrame(Frame(64, 48, i * 20));
  const VideoResult result = writer.Finish();
  EXPECT_TRUE(result.video);
  EXPECT_EQ(result.frames, 12);
  EXPECT_EQ(result.path, path);
  const std::string probe =
      Shell("ffprobe -v error -count_frames -select_streams v:0 -show_entries "
          "stream=nb_read_frames,width,height -of csv=p=0 " + path);
  EXPECT_EQ(probe, "64,48,12\n");
}

TEST_F(VideoTest, WithoutFfmpegANumberedPngSequenceAndANote) {
  const std::string path = (dir_ / "clip.mp4").string();
  VideoWriter writer(path, VideoOptions{.frame_rate = 25, .ffmpeg = "/nonexistent/ffmpeg"});
  for (int i = 0; i < 3; ++i) writer.AddFrame(Frame(8, 6, i));
  const VideoResult result = writer.Finish();
  EXPECT_FALSE(result.video);
  EXPECT_EQ(result.frames, 3);
  EXPECT_EQ(result.path, (dir_ / "clip-000000.png").string());
  EXPECT_EQ(result.pattern, (dir_ / "clip-%06d.png").string());
  EXPECT_NE(result.note.find("PNG sequence"), std::string::npos) << result.note;
  for (int i = 0; i < 3; ++i) {
    const fs::path frame = dir_ / ("clip-00000" + std::to_string(i) + ".png");
    ASSERT_TRUE(fs::exists(frame)) << frame;
  }
  EXPECT_FALSE(fs::exists(dir_ / "clip.mp4"));
}

TEST_F(VideoTest, FfmpegFailureIsReportedWithItsMessage) {
  if (!HaveFfmpeg()) GTEST_SKIP() << "ffmpeg is not installed";
  VideoWriter writer((dir_ / "no" / "such" / "dir.mp4").string());
  try {
    writer.AddFrame(Frame(8, 6, 0));
    writer.Finish();
    ADD_FAILURE() << "an unwritable path succeeded";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kUnavailable);
    EXPECT_NE(std::string(e.what()).find("ffmpeg"), std::string::npos) << e.what();
  }
}

Image RawFrame(int width, int height, int shade) {
  Image image{.width = width, .height = height};
  image.rgba.assign(static_cast<std::size_t>(width) * height * 4, 255);
  for (std::size_t i = 0; i < image.rgba.size(); i += 4) image.rgba[i] = static_cast<uint8_t>(shade);
  return image;
}

// Raw mode: RGBA images straight to ffmpeg (no PNG on the way).
TEST_F(VideoTest, RawImagesMakeTheSameVideo) {
  if (!HaveFfmpeg()) GTEST_SKIP() << "ffmpeg is not installed";
  const std::string path = (dir_ / "raw.mp4").string();
  VideoWriter writer(path, VideoOptions{.frame_rate = 10, .raw_width = 64, .raw_height = 48});
  for (int i = 0; i < 12; ++i) writer.AddImage(RawFrame(64, 48, i * 20));
  std::string message;
  try {
    writer.AddImage(RawFrame(32, 48, 0));
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kInvalidArgument);
    message = e.what();
  }
  EXPECT_EQ(message, "video frame 32x48 (6144 bytes) is not the video's 64x48 RGBA");
  EXPECT_THROW(writer.AddFrame(Frame(64, 48, 0)), Error) << "PNG frames in raw mode";
  const VideoResult result = writer.Finish();
  EXPECT_TRUE(result.video);
  EXPECT_EQ(result.frames, 12);
  EXPECT_EQ(Shell("ffprobe -v error -count_frames -select_streams v:0 -show_entries "
                  "stream=nb_read_frames,width,height -of csv=p=0 " + path),
            "64,48,12\n");
}

TEST_F(VideoTest, RawImagesWithoutFfmpegBecomeThePngSequence) {
  const std::string path = (dir_ / "raw.mp4").string();
  VideoWriter writer(path, VideoOptions{.frame_rate = 25, .ffmpeg = "/nonexistent/ffmpeg",
                                        .raw_width = 8, .raw_height = 6});
  for (int i = 0; i < 2; ++i) writer.AddImage(RawFrame(8, 6, 100 + i));
  const VideoResult result = writer.Finish();
  EXPECT_FALSE(result.video);
  EXPECT_EQ(result.frames, 2);
  std::ifstream in(dir_ / "raw-000001.png", std::ios::binary);
  const std::vector<uint8_t> png((std::istreambuf_iterator<char>(in)), {});
  EXPECT_TRUE(DecodePng(png) == RawFrame(8, 6, 101));
}

TEST(VideoOptionsTest, BadRateOrPathIsRefused) {
  EXPECT_THROW(VideoWriter("x.mp4", VideoOptions{.raw_width = 0, .raw_height = 5}), Error);
  EXPECT_THROW(VideoWriter("x.mp4", VideoOptions{.raw_width = 5000, .raw_height = 5}), Error);
  EXPECT_THROW(VideoWriter("x.mp4", VideoOptions{.ffmpeg = "/nonexistent/ffmpeg"})
                   .AddImage(RawFrame(2, 2, 0)),
               Error)
      << "images need raw mode";
  EXPECT_THROW(VideoWriter("x.mp4", VideoOptions{.frame_rate = 0}), Error);
  EXPECT_THROW(VideoWriter("", VideoOptions{}), Error);
}

}  // namespace
}  // namespace yamor::render
