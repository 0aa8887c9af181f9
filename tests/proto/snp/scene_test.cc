// The scene snapshot codec (docs/snp.md, "Scene snapshot"): layout, round
// trips, and every rule the decoder enforces.
#include "proto/snp/scene.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>

#include "common/status.h"

namespace yamor::snp {
namespace {

SceneSnapshot Example() {
  SceneSnapshot s;
  s.time = 2.5;
  s.slope = 0.1f;
  s.slope_direction = -1.0f;
  s.led = {0.0f, 0.0f, 0.028f};
  s.shape = {SceneShapeBox{.part = 0, .center = {0, 0, 0}, .size = {0.07f, 0.05f, 0.05f}},
             SceneShapeBox{.part = 1, .center = {0.04f, 0, 0}, .size = {0.01f, 0.06f, 0.02f}}};
  s.modules = {
      SceneModule{.id = 3, .flags = kSceneModuleCentral,
                  .body = {.position = {0.1f, 0.2f, 0.03f}},
                  .handle = {.position = {0.127f, 0.2f, 0.03f}, .orientation = {0.f, 1.f, 0.f, 0.f}}},
      SceneModule{.id = 9, .flags = kSceneModuleLoose | kSceneModuleDefective}};
  s.boxes = {SceneStaticBox{.pose = {.position = {1, 0, 0.1f}}, .size = {0.5f, 0.5f, 0.2f}}};
  return s;
}

std::string DecodeError(const std::vector<uint8_t>& bytes) {
  try {
    DecodeSceneSnapshot(bytes);
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kInvalidArgument);
    return e.what();
  }
  return "decoded";
}

std::string EncodeError(const SceneSnapshot& s) {
  try {
    EncodeSceneSnapshot(s);
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kInvalidArgument);
    return e.what();
  }
  return "encoded";
}

TEST(SceneSnapshotTest, LayoutIsAsDocumented) {
  const std::vector<uint8_t> bytes = EncodeSceneSnapshot(Example());
  ASSERT_EQ(bytes.size(), 36u + 2 * 25 + 2 * 58 + 1 * 40);
  EXPECT_EQ(bytes[0], kSceneFormatVersion);
  EXPECT_EQ(bytes[1], 0);
  EXPECT_EQ(bytes[2], 2);  // shape boxes
  EXPECT_EQ(bytes[3], 2);  // modules
  EXPECT_EQ(bytes[4], 1);  // static boxes, u16
  EXPECT_EQ(bytes[5], 0);
  double time = 0;
  std::memcpy(&time, &bytes[8], 8);
  EXPECT_EQ(time, 2.5);
  EXPECT_EQ(bytes[36], 0);  // first shape box: body
  EXPECT_EQ(bytes[36 + 25], 1);
  const std::size_t module0 = 36 + 2 * 25;
  EXPECT_EQ(bytes[module0], 3);
  EXPECT_EQ(bytes[module0 + 1], kSceneModuleCentral);
  float x = 0;
  std::memcpy(&x, &bytes[module0 + 2], 4);
  EXPECT_EQ(x, 0.1f);
  EXPECT_EQ(bytes[module0 + 58], 9);
}

TEST(SceneSnapshotTest, RoundTripsAndReencodesToTheSameBytes) {
  const SceneSnapshot s = Example();
  const std::vector<uint8_t> bytes = EncodeSceneSnapshot(s);
  EXPECT_EQ(DecodeSceneSnapshot(bytes), s);
  EXPECT_EQ(EncodeSceneSnapshot(DecodeSceneSnapshot(bytes)), bytes);
  SceneSnapshot empty;
  empty.shape = s.shape;
  EXPECT_EQ(DecodeSceneSnapshot(EncodeSceneSnapshot(empty)), empty);
}

TEST(SceneSnapshotTest, DecoderRefusesMalformedBytesNamingWhy) {
  const std::vector<uint8_t> good = EncodeSceneSnapshot(Example());
  EXPECT_EQ(DecodeError({1, 0, 1}), "scene snapshot: 3 bytes, shorter than the 36-byte header");
  std::vector<uint8_t> b = good;
  b[0] = 2;
  EXPECT_EQ(DecodeError(b), "scene snapshot: version 2 at offset 0, expected 1");
  b = good;
  b[1] = 1;
  EXPECT_EQ(DecodeError(b), "scene snapshot: reserved byte at offset 1 is 0x01, not 0");
  b = good;
  b.pop_back();
  EXPECT_EQ(DecodeError(b),
            "scene snapshot: 241 bytes, but 2 shape boxes, 2 modules and 1 static boxes take 242");
  b = good;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(&b[36 + 50 + 2], &nan, 4);
  EXPECT_EQ(DecodeError(b), "scene snapshot: modules[0].body.position[0] is not finite: nan");
  b = good;
  b[36 + 50 + 58] = 2;  // second id below the first
  EXPECT_EQ(DecodeError(b),
            "scene snapshot: modules[1].id 2 does not follow 3 (ids strictly ascending)");
  b = good;
  b[36 + 50 + 1] = 0x10;
  EXPECT_EQ(DecodeError(b), "scene snapshot: modules[0].flags 0x10 has reserved bits set");
}

TEST(SceneSnapshotTest, EncoderRefusesWhatTheDecoderWould) {
  SceneSnapshot s = Example();
  s.modules[1].flags |= kSceneModuleCentral;
  EXPECT_EQ(EncodeError(s), "scene snapshot: 2 modules are flagged central, expected exactly 1");
  s = Example();
  s.modules[0].body.orientation = {1.f, 1.f, 0.f, 0.f};
  EXPECT_EQ(EncodeError(s).substr(0, 50), "scene snapshot: modules[0].body.orientation has no");
  s = Example();
  s.shape.clear();
  EXPECT_EQ(EncodeError(s), "scene snapshot: 0 shape boxes, expected 1..16");
  s = Example();
  s.boxes[0].size[1] = 0.0f;
  EXPECT_EQ(EncodeError(s), "scene snapshot: boxes[0].size[1] = 0 is not > 0");
  s = Example();
  s.slope = 2.0f;
  EXPECT_EQ(EncodeError(s), "scene snapshot: slope 2 rad is outside [0, pi/2)");
  s = Example();
  s.modules[0].id = 255;
  EXPECT_EQ(EncodeError(s), "scene snapshot: modules[0].id 255 out of range 0..254");
  s = Example();
  s.time = std::numeric_limits<double>::infinity();
  EXPECT_EQ(EncodeError(s), "scene snapshot: time is not finite: inf");
}

// The scene_snapshot_fuzzer's seed (tests/fuzz/corpus) is Example()'s
// bytes; regenerate with YAMOR_WRITE_SNP_CORPUS=1.
TEST(SceneSnapshotTest, FuzzSeedIsTheExample) {
  const std::filesystem::path path = std::filesystem::path(YAMOR_SOURCE_DIR) /
                                     "tests/fuzz/corpus/scene_snapshot_fuzzer/example";
  const std::vector<uint8_t> bytes = EncodeSceneSnapshot(Example());
  if (std::getenv("YAMOR_WRITE_SNP_CORPUS") != nullptr) {
    std::filesystem::create_directories(path.parent_path());
    std::ofstream out(path, std::ios::binary);
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  }
  std::ifstream in(path, std::ios::binary);
  ASSERT_TRUE(in) << "missing " << path;
  const std::vector<uint8_t> file((std::istreambuf_iterator<char>(in)),
                                  std::istreambuf_iterator<char>());
  EXPECT_EQ(file, bytes) << "seed is stale (regenerate with YAMOR_WRITE_SNP_CORPUS=1)";
}

}  // namespace
}  // namespace yamor::snp
