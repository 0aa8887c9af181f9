// VideoWriter: an MP4 through the ffmpeg tool (ffprobe checks it), and the
// numbered PNG sequence when ffmpeg is missing.
#include "physics/render/video.h"

#include <gtest/gtest.h>
#include <pthread.h>

#include <csignal>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>

#include <fmt/format.h>

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

// ffmpeg starts with no signal blocked and SIGPIPE not ignored, whatever the
// caller's thread does (yamord blocks SIGINT and SIGTERM in every thread).
TEST_F(VideoTest, FfmpegStartsWithNoSignalBlockedOrPipeSignalIgnored) {
  // A stand-in for ffmpeg that writes its signal state to the output path.
  const fs::path script = dir_ / "fake-ffmpeg.sh";
  std::ofstream(script) << "#!/bin/sh\nfor last; do :; done\ncat > /dev/null\n"
                           "grep -E '^Sig(Blk|Ign)' /proc/self/status > \"$last\"\n";
  fs::permissions(script, fs::perms::owner_all);
  sigset_t blocked, previous;
  sigemptyset(&blocked);
  sigaddset(&blocked, SIGINT);
  sigaddset(&blocked, SIGTERM);
  ASSERT_EQ(pthread_sigmask(SIG_BLOCK, &blocked, &previous), 0);
  const fs::path out = dir_ / "signals.txt";
  VideoWriter writer(out.string(), VideoOptions{.ffmpeg = script.string()});
  writer.AddFrame(Frame(8, 6, 0));
  const VideoResult result = writer.Finish();
  pthread_sigmask(SIG_SETMASK, &previous, nullptr);
  ASSERT_TRUE(result.video) << result.note;
  std::ifstream in(out);
  const std::string state((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(state.find("SigBlk:\t0000000000000000"), std::string::npos) << state;
  const auto ign = state.find("SigIgn:\t");
  ASSERT_NE(ign, std::string::npos) << state;
  const unsigned long long ignored = std::stoull(state.substr(ign + 8, 16), nullptr, 16);
  EXPECT_EQ(ignored & (1ULL << (SIGPIPE - 1)), 0u) << "SIGPIPE ignored: " << state;
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

// RgbaToYuv420 against the BT.601 limited-range formulas in floating
// point: luma per pixel, chroma from each 2x2 block's mean colour.
TEST(RgbaToYuv420Test, MatchesTheBt601FormulasWithinOneStep) {
  Image image{.width = 6, .height = 4};
  for (int i = 0; i < 6 * 4; ++i) {
    // Primaries, black, white and greys, then a spread of colours.
    const std::array<std::array<int, 3>, 8> fixed = {
        {{0, 0, 0}, {255, 255, 255}, {255, 0, 0}, {0, 255, 0},
         {0, 0, 255}, {128, 128, 128}, {200, 194, 179}, {51, 140, 230}}};
    const std::array<int, 3> c =
        i < 8 ? fixed[i] : std::array<int, 3>{(i * 37) % 256, (i * 91) % 256, (i * 53) % 256};
    image.rgba.insert(image.rgba.end(), {static_cast<uint8_t>(c[0]), static_cast<uint8_t>(c[1]),
                                         static_cast<uint8_t>(c[2]), 255});
  }
  std::vector<uint8_t> yuv;
  RgbaToYuv420(image, yuv);
  ASSERT_EQ(yuv.size(), 6u * 4u + 2u * 3u * 2u);
  auto px = [&](int x, int y, int c) { return image.rgba[(y * 6 + x) * 4 + c] / 255.0; };
  for (int y = 0; y < 4; ++y) {
    for (int x = 0; x < 6; ++x) {
      const double want = 16 + 65.481 * px(x, y, 0) + 128.553 * px(x, y, 1) + 24.966 * px(x, y, 2);
      EXPECT_NEAR(yuv[y * 6 + x], want, 1.0) << x << "," << y;
    }
  }
  for (int y = 0; y < 2; ++y) {
    for (int x = 0; x < 3; ++x) {
      double r = 0, g = 0, b = 0;
      for (int dy = 0; dy < 2; ++dy) {
        for (int dx = 0; dx < 2; ++dx) {
          r += px(2 * x + dx, 2 * y + dy, 0) / 4;
          g += px(2 * x + dx, 2 * y + dy, 1) / 4;
          b += px(2 * x + dx, 2 * y + dy, 2) / 4;
        }
      }
      const double cb = 128 - 37.797 * r - 74.203 * g + 112.0 * b;
      const double cr = 128 + 112.0 * r - 93.786 * g - 18.214 * b;
      EXPECT_NEAR(yuv[24 + y * 3 + x], cb, 1.0) << x << "," << y;
      EXPECT_NEAR(yuv[24 + 6 + y * 3 + x], cr, 1.0) << x << "," << y;
    }
  }
  // The extremes: black is Y 16, white Y 235, greys have no colour.
  EXPECT_EQ(yuv[0], 16);
  EXPECT_EQ(yuv[1], 235);
}

// Every sample of every plane, at even and odd sizes (whole 2x2 blocks and
// those that take padding go different ways), against the formulas, with
// the padding black.
TEST(RgbaToYuv420Test, EverySampleAtEvenAndOddSizes) {
  uint32_t state = 12345;
  auto next = [&state] {
    state = state * 1664525u + 1013904223u;
    return static_cast<uint8_t>(state >> 24);
  };
  for (auto [w, h] : {std::pair{1, 1}, std::pair{2, 2}, std::pair{3, 2}, std::pair{2, 3},
                      std::pair{5, 7}, std::pair{8, 6}, std::pair{33, 17}, std::pair{320, 240}}) {
    SCOPED_TRACE(fmt::format("{}x{}", w, h));
    Image image{.width = w, .height = h};
    for (int i = 0; i < w * h; ++i) {
      image.rgba.insert(image.rgba.end(), {next(), next(), next(), 255});
    }
    std::vector<uint8_t> yuv;
    RgbaToYuv420(image, yuv);
    const int ew = w + (w & 1);
    const int eh = h + (h & 1);
    ASSERT_EQ(yuv.size(), static_cast<std::size_t>(ew * eh + 2 * (ew / 2) * (eh / 2)));
    auto px = [&](int x, int y, int c) {
      return x < w && y < h ? image.rgba[(y * w + x) * 4 + c] / 255.0 : 0.0;  // padding: black
    };
    int bad = 0;
    for (int y = 0; y < eh; ++y) {
      for (int x = 0; x < ew; ++x) {
        const double want =
            16 + 65.481 * px(x, y, 0) + 128.553 * px(x, y, 1) + 24.966 * px(x, y, 2);
        if (std::abs(yuv[y * ew + x] - want) > 1.0 && ++bad < 5) {
          ADD_FAILURE() << "Y at " << x << "," << y << ": " << int{yuv[y * ew + x]} << " not "
                        << want;
        }
      }
    }
    const int cw = ew / 2;
    const int ch = eh / 2;
    for (int y = 0; y < ch; ++y) {
      for (int x = 0; x < cw; ++x) {
        double r = 0, g = 0, b = 0;
        for (int d = 0; d < 4; ++d) {
          r += px(2 * x + d % 2, 2 * y + d / 2, 0) / 4;
          g += px(2 * x + d % 2, 2 * y + d / 2, 1) / 4;
          b += px(2 * x + d % 2, 2 * y + d / 2, 2) / 4;
        }
        const double cb = 128 - 37.797 * r - 74.203 * g + 112.0 * b;
        const double cr = 128 + 112.0 * r - 93.786 * g - 18.214 * b;
        const int got_cb = yuv[ew * eh + y * cw + x];
        const int got_cr = yuv[ew * eh + cw * ch + y * cw + x];
        if ((std::abs(got_cb - cb) > 1.0 || std::abs(got_cr - cr) > 1.0) && ++bad < 5) {
          ADD_FAILURE() << "Cb/Cr at " << x << "," << y << ": " << got_cb << "/" << got_cr
                        << " not " << cb << "/" << cr;
        }
      }
    }
    EXPECT_EQ(bad, 0);
  }
}

TEST(RgbaToYuv420Test, OddSizesArePaddedWithBlackAndBadImagesRefused) {
  Image image{.width = 3, .height = 3};
  image.rgba.assign(3 * 3 * 4, 255);  // white
  std::vector<uint8_t> yuv;
  RgbaToYuv420(image, yuv);
  ASSERT_EQ(yuv.size(), 4u * 4u + 2u * 2u * 2u);
  for (int y = 0; y < 4; ++y) {
    for (int x = 0; x < 4; ++x) {
      EXPECT_EQ(yuv[y * 4 + x], (x < 3 && y < 3) ? 235 : 16) << x << "," << y;
    }
  }
  EXPECT_EQ(yuv[16], 128);  // a white block: no colour
  EXPECT_EQ(yuv[20], 128);
  Image broken{.width = 4, .height = 4};
  broken.rgba.assign(10, 0);
  EXPECT_THROW(RgbaToYuv420(broken, yuv), Error);
}

// An odd-sized raw video comes out one column and row larger, every frame
// there, its colours those of the frames (decoded back through ffmpeg).
TEST_F(VideoTest, RawImagesOfOddSizeArePaddedAndKeepTheirColours) {
  if (!HaveFfmpeg()) GTEST_SKIP() << "ffmpeg is not installed";
  const std::string path = (dir_ / "odd.mp4").string();
  VideoWriter writer(path, VideoOptions{.frame_rate = 25, .raw_width = 63, .raw_height = 47});
  Image frame{.width = 63, .height = 47};
  for (int i = 0; i < 63 * 47; ++i) frame.rgba.insert(frame.rgba.end(), {51, 140, 230, 255});
  for (int i = 0; i < 5; ++i) writer.AddImage(frame);
  const VideoResult result = writer.Finish();
  EXPECT_EQ(result.frames, 5);
  EXPECT_EQ(Shell("ffprobe -v error -count_frames -select_streams v:0 -show_entries "
                  "stream=nb_read_frames,width,height -of csv=p=0 " + path),
            "64,48,5\n");
  // The middle pixel of the last frame, decoded to RGB.
  const std::string rgb =
      Shell("ffmpeg -v error -i " + path +
            " -vf 'select=eq(n\\,4),format=rgb24,crop=1:1:30:20' -f rawvideo -pix_fmt rgb24 -");
  ASSERT_EQ(rgb.size(), 3u);
  EXPECT_NEAR(static_cast<uint8_t>(rgb[0]), 51, 4);
  EXPECT_NEAR(static_cast<uint8_t>(rgb[1]), 140, 4);
  EXPECT_NEAR(static_cast<uint8_t>(rgb[2]), 230, 4);
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
