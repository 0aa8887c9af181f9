// The scene snapshot: what a simulation shows a renderer (every module's body
// and handle pose, the module's shape, the ground's slope, static boxes), as
// the bytes the bridge serves in SceneChunk replies to ReadScene. Layout and
// rules: docs/snp.md, "Scene snapshot".
//
// Thread-safety: pure functions and plain values.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace yamor::snp {

/// Version byte of the scene snapshot format.
inline constexpr uint8_t kSceneFormatVersion = 1;
/// Most boxes in the module's shape.
inline constexpr std::size_t kMaxSceneShapeBoxes = 16;
/// Most modules in a snapshot (module ids are 0..254).
inline constexpr std::size_t kMaxSceneModules = 255;
/// Most static boxes (obstacles) in a snapshot.
inline constexpr std::size_t kMaxSceneStaticBoxes = 1024;
/// Largest box edge and largest coordinate magnitude [m].
inline constexpr float kMaxSceneExtent = 1e4f;

/// A rigid pose in float32: position [m] and unit quaternion (w, x, y, z).
struct ScenePose {
  std::array<float, 3> position{};                  ///< World frame [m].
  std::array<float, 4> orientation{1.f, 0.f, 0.f, 0.f};  ///< w, x, y, z.
  friend bool operator==(const ScenePose&, const ScenePose&) = default;
};

/// One box of the module's shape, axis-aligned in its part's frame.
struct SceneShapeBox {
  uint8_t part = 0;                  ///< 0 body, 1 handle.
  std::array<float, 3> center{};     ///< Centre in the part frame [m].
  std::array<float, 3> size{};       ///< Full edge lengths [m] (> 0).
  friend bool operator==(const SceneShapeBox&, const SceneShapeBox&) = default;
};

/// Flag bits of SceneModule::flags.
inline constexpr uint8_t kSceneModuleCentral = 0x01;   ///< The tracked module (LED).
inline constexpr uint8_t kSceneModuleLoose = 0x02;     ///< In the world, not in the robot.
inline constexpr uint8_t kSceneModuleDefective = 0x04; ///< Marked defective.
/// Every defined flag bit.
inline constexpr uint8_t kSceneModuleFlags = 0x07;

/// One module in the world (modules put away are not in the snapshot).
struct SceneModule {
  uint8_t id = 0;        ///< Module id on the wire (0..254).
  uint8_t flags = 0;     ///< kSceneModule* bits.
  ScenePose body;        ///< Body frame in the world.
  ScenePose handle;      ///< Handle frame in the world.
  friend bool operator==(const SceneModule&, const SceneModule&) = default;
};

/// A static box of the terrain.
struct SceneStaticBox {
  ScenePose pose;                ///< Centre and orientation in the world.
  std::array<float, 3> size{};   ///< Full edge lengths [m] (> 0).
  friend bool operator==(const SceneStaticBox&, const SceneStaticBox&) = default;
};

/// The whole snapshot.
struct SceneSnapshot {
  double time = 0.0;                    ///< Simulated time [s].
  float slope = 0.0f;                   ///< Ground tilt [rad], [0, π/2).
  float slope_direction = 0.0f;         ///< Downhill azimuth [rad].
  std::array<float, 3> led{};           ///< LED position in the central module's body frame [m].
  std::vector<SceneShapeBox> shape;     ///< The module's boxes (1..16).
  std::vector<SceneModule> modules;     ///< Ids strictly ascending; one central when any.
  std::vector<SceneStaticBox> boxes;    ///< Static boxes (0..1024).
  friend bool operator==(const SceneSnapshot&, const SceneSnapshot&) = default;
};

/// The snapshot's bytes; throws yamor::Error(INVALID_ARGUMENT) naming the
/// field for a value the format cannot carry (the rules of DecodeSceneSnapshot).
std::vector<uint8_t> EncodeSceneSnapshot(const SceneSnapshot& scene);

/// Parses a snapshot; throws yamor::Error(INVALID_ARGUMENT) naming the field
/// and byte offset (wrong version, sizes, non-finite or out-of-range values,
/// non-unit quaternions, unsorted ids, not exactly one central module).
/// Accepted bytes re-encode to the same bytes.
SceneSnapshot DecodeSceneSnapshot(std::span<const uint8_t> bytes);

}  // namespace yamor::snp
