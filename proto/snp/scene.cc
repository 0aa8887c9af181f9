#include "proto/snp/scene.h"

#include <bit>
#include <cmath>
#include <string>

#include <fmt/format.h>

#include "common/status.h"

namespace yamor::snp {
namespace {

constexpr std::size_t kHeaderSize = 36;
constexpr std::size_t kShapeBoxSize = 25;
constexpr std::size_t kModuleSize = 58;
constexpr std::size_t kStaticBoxSize = 40;
constexpr double kQuaternionNormTolerance = 1e-3;

template <class... Args>
[[noreturn]] void Fail(fmt::format_string<Args...> format, Args&&... args) {
  throw Error(StatusCode::kInvalidArgument,
              "scene snapshot: " + fmt::format(format, std::forward<Args>(args)...));
}

void CheckCoordinate(float value, const std::string& field) {
  if (!std::isfinite(value)) Fail("{} is not finite: {}", field, value);
  if (std::fabs(value) > kMaxSceneExtent) {
    Fail("{} = {} is beyond ±{} m", field, value, kMaxSceneExtent);
  }
}

void CheckSize(const std::array<float, 3>& size, const std::string& field) {
  for (int i = 0; i < 3; ++i) {
    const std::string name = fmt::format("{}[{}]", field, i);
    CheckCoordinate(size[i], name);
    if (!(size[i] > 0.0f)) Fail("{} = {} is not > 0", name, size[i]);
  }
}

void CheckPose(const ScenePose& pose, const std::string& field) {
  for (int i = 0; i < 3; ++i) CheckCoordinate(pose.position[i], fmt::format("{}.position[{}]", field, i));
  double norm2 = 0.0;
  for (int i = 0; i < 4; ++i) {
    const float q = pose.orientation[i];
    if (!std::isfinite(q)) Fail("{}.orientation[{}] is not finite: {}", field, i, q);
    norm2 += static_cast<double>(q) * q;
  }
  if (std::fabs(std::sqrt(norm2) - 1.0) > kQuaternionNormTolerance) {
    Fail("{}.orientation has norm {}, not 1", field, std::sqrt(norm2));
  }
}

// The rules both directions share (docs/snp.md, "Scene snapshot").
void Validate(const SceneSnapshot& scene) {
  if (!std::isfinite(scene.time)) Fail("time is not finite: {}", scene.time);
  if (!(scene.slope >= 0.0f && scene.slope < 1.5707963f)) {
    Fail("slope {} rad is outside [0, pi/2)", scene.slope);
  }
  if (!std::isfinite(scene.slope_direction)) {
    Fail("slope_direction is not finite: {}", scene.slope_direction);
  }
  for (int i = 0; i < 3; ++i) CheckCoordinate(scene.led[i], fmt::format("led[{}]", i));
  if (scene.shape.empty() || scene.shape.size() > kMaxSceneShapeBoxes) {
    Fail("{} shape boxes, expected 1..{}", scene.shape.size(), kMaxSceneShapeBoxes);
  }
  for (std::size_t i = 0; i < scene.shape.size(); ++i) {
    const SceneShapeBox& box = scene.shape[i];
    if (box.part > 1) Fail("shape[{}].part {} is not 0 (body) or 1 (handle)", i, box.part);
    for (int k = 0; k < 3; ++k) CheckCoordinate(box.center[k], fmt::format("shape[{}].center[{}]", i, k));
    CheckSize(box.size, fmt::format("shape[{}].size", i));
  }
  if (scene.modules.size() > kMaxSceneModules) {
    Fail("{} modules, at most {}", scene.modules.size(), kMaxSceneModules);
  }
  int central = 0;
  for (std::size_t i = 0; i < scene.modules.size(); ++i) {
    const SceneModule& m = scene.modules[i];
    if (m.id > 254) Fail("modules[{}].id {} out of range 0..254", i, m.id);
    if (i > 0 && m.id <= scene.modules[i - 1].id) {
      Fail("modules[{}].id {} does not follow {} (ids strictly ascending)", i, m.id,
           scene.modules[i - 1].id);
    }
    if ((m.flags & ~kSceneModuleFlags) != 0) {
      Fail("modules[{}].flags 0x{:02x} has reserved bits set", i, m.flags);
    }
    if ((m.flags & kSceneModuleCentral) != 0) ++central;
    CheckPose(m.body, fmt::format("modules[{}].body", i));
    CheckPose(m.handle, fmt::format("modules[{}].handle", i));
  }
  if (!scene.modules.empty() && central != 1) {
    Fail("{} modules are flagged central, expected exactly 1", central);
  }
  if (scene.boxes.size() > kMaxSceneStaticBoxes) {
    Fail("{} static boxes, at most {}", scene.boxes.size(), kMaxSceneStaticBoxes);
  }
  for (std::size_t i = 0; i < scene.boxes.size(); ++i) {
    CheckPose(scene.boxes[i].pose, fmt::format("boxes[{}].pose", i));
    CheckSize(scene.boxes[i].size, fmt::format("boxes[{}].size", i));
  }
}

class ByteWriter {
 public:
  void U8(uint8_t v) { out_.push_back(v); }
  void U16(uint16_t v) { Put(v, 2); }
  void F32(float v) { Put(std::bit_cast<uint32_t>(v), 4); }
  void F64(double v) { Put(std::bit_cast<uint64_t>(v), 8); }
  void Vec3(const std::array<float, 3>& v) {
    for (float x : v) F32(x);
  }
  void Pose(const ScenePose& p) {
    Vec3(p.position);
    for (float q : p.orientation) F32(q);
  }
  std::vector<uint8_t> Take() { return std::move(out_); }

 private:
  void Put(uint64_t bits, int size) {
    for (int i = 0; i < size; ++i) out_.push_back(static_cast<uint8_t>(bits >> (8 * i)));
  }
  std::vector<uint8_t> out_;
};

class ByteReader {
 public:
  explicit ByteReader(std::span<const uint8_t> in) : in_(in) {}
  uint8_t U8() { return static_cast<uint8_t>(Get(1)); }
  uint16_t U16() { return static_cast<uint16_t>(Get(2)); }
  float F32() { return std::bit_cast<float>(static_cast<uint32_t>(Get(4))); }
  double F64() { return std::bit_cast<double>(Get(8)); }
  std::array<float, 3> Vec3() { return {F32(), F32(), F32()}; }
  ScenePose Pose() {
    ScenePose p;
    p.position = Vec3();
    for (float& q : p.orientation) q = F32();
    return p;
  }
  std::size_t position() const { return pos_; }

 private:
  uint64_t Get(int size) {
    // DecodeSceneSnapshot checks the total size before reading.
    YAMOR_CHECK(pos_ + static_cast<std::size_t>(size) <= in_.size(), "scene read past the end");
    uint64_t bits = 0;
    for (int i = 0; i < size; ++i) bits |= static_cast<uint64_t>(in_[pos_ + i]) << (8 * i);
    pos_ += static_cast<std::size_t>(size);
    return bits;
  }
  std::span<const uint8_t> in_;
  std::size_t pos_ = 0;
};

}  // namespace

std::vector<uint8_t> EncodeSceneSnapshot(const SceneSnapshot& scene) {
  Validate(scene);
  ByteWriter w;
  w.U8(kSceneFormatVersion);
  w.U8(0);  // reserved
  w.U8(static_cast<uint8_t>(scene.shape.size()));
  w.U8(static_cast<uint8_t>(scene.modules.size()));
  w.U16(static_cast<uint16_t>(scene.boxes.size()));
  w.U16(0);  // reserved
  w.F64(scene.time);
  w.F32(scene.slope);
  w.F32(scene.slope_direction);
  w.Vec3(scene.led);
  for (const SceneShapeBox& box : scene.shape) {
    w.U8(box.part);
    w.Vec3(box.center);
    w.Vec3(box.size);
  }
  for (const SceneModule& m : scene.modules) {
    w.U8(m.id);
    w.U8(m.flags);
    w.Pose(m.body);
    w.Pose(m.handle);
  }
  for (const SceneStaticBox& box : scene.boxes) {
    w.Pose(box.pose);
    w.Vec3(box.size);
  }
  return w.Take();
}

SceneSnapshot DecodeSceneSnapshot(std::span<const uint8_t> bytes) {
  if (bytes.size() < kHeaderSize) {
    Fail("{} bytes, shorter than the {}-byte header", bytes.size(), kHeaderSize);
  }
  ByteReader r(bytes);
  const uint8_t version = r.U8();
  if (version != kSceneFormatVersion) {
    Fail("version {} at offset 0, expected {}", version, kSceneFormatVersion);
  }
  if (const uint8_t reserved = r.U8(); reserved != 0) {
    Fail("reserved byte at offset 1 is 0x{:02x}, not 0", reserved);
  }
  const std::size_t shape_count = r.U8();
  const std::size_t module_count = r.U8();
  const std::size_t box_count = r.U16();
  if (const uint16_t reserved = r.U16(); reserved != 0) {
    Fail("reserved bytes at offset 6 are 0x{:04x}, not 0", reserved);
  }
  const std::size_t expected = kHeaderSize + shape_count * kShapeBoxSize +
                               module_count * kModuleSize + box_count * kStaticBoxSize;
  if (bytes.size() != expected) {
    Fail("{} bytes, but {} shape boxes, {} modules and {} static boxes take {}", bytes.size(),
         shape_count, module_count, box_count, expected);
  }
  SceneSnapshot scene;
  scene.time = r.F64();
  scene.slope = r.F32();
  scene.slope_direction = r.F32();
  scene.led = r.Vec3();
  scene.shape.resize(shape_count);
  for (SceneShapeBox& box : scene.shape) {
    box.part = r.U8();
    box.center = r.Vec3();
    box.size = r.Vec3();
  }
  scene.modules.resize(module_count);
  for (SceneModule& m : scene.modules) {
    m.id = r.U8();
    m.flags = r.U8();
    m.body = r.Pose();
    m.handle = r.Pose();
  }
  scene.boxes.resize(box_count);
  for (SceneStaticBox& box : scene.boxes) {
    box.pose = r.Pose();
    box.size = r.Vec3();
  }
  YAMOR_CHECK(r.position() == bytes.size(), "scene bytes left after the last field");
  Validate(scene);
  return scene;
}

}  // namespace yamor::snp
