// Rendering cost for issue 14 (docs/benchmarks.md, "Rendering"): frames per
// second of the headless renderer at 320x240 and 640x480 for the quadruped
// and a 64-module snake (render only, and render + PNG), and the CPU cost of
// a 20-s video at 25 fps (500 frames, rendered, encoded and piped to ffmpeg)
// against the 20-s evaluation it shows. A plain program printing a table
// (tools/bench/run.sh's plain_programs).
//
//   render_bench [--frames N] [--runs N] [--video-only | --no-video] [--breakdown] [--png DIR]
//                [--yuv FILE] [--backend osmesa|egl]
//
// --png DIR also writes a sample frame of each robot and camera there;
// --yuv FILE the raw video's 500 frames as ffmpeg reads them (yuv420p,
// 320x240), to time encoders alone.
// CPU times are the whole process's (llvmpipe rasterises on its own
// threads) plus, for the video, ffmpeg's (a child process).
#include <sys/resource.h>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "bridge/robot.h"
#include "bridge/scene.h"
#include "common/log.h"
#include "cpg/config_xml.h"
#include "host/config_frames.h"
#include "physics/render/image.h"
#include "physics/render/raster_threads.h"
#include "physics/render/renderer.h"
#include "physics/render/video.h"

namespace {

using yamor::render::Camera;
using yamor::render::CameraKind;
using yamor::render::Renderer;
using yamor::render::Scene;

double ProcessCpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

double ChildrenCpuSeconds() {
  rusage usage{};
  getrusage(RUSAGE_CHILDREN, &usage);
  auto seconds = [](const timeval& t) { return t.tv_sec + 1e-6 * t.tv_usec; };
  return seconds(usage.ru_utime) + seconds(usage.ru_stime);
}

// A snake of n modules as configs/worlds/snake.xml builds it.
yamor::physics::Morphology SnakeMorphology(int n) {
  std::vector<yamor::physics::MorphologyModule> modules;
  std::vector<yamor::physics::MorphologyConnection> connections;
  for (int id = 0; id < n; ++id) {
    modules.push_back({.id = id});
    if (id > 0) {
      connections.push_back({.from = id,
                             .from_connector = yamor::physics::ConnectorId::kFront,
                             .to = id - 1,
                             .to_connector = yamor::physics::ConnectorId::kRear});
    }
  }
  return yamor::physics::Morphology::Build(0, std::move(modules), std::move(connections),
                                           Eigen::Vector3d::Zero(), "snake" + std::to_string(n));
}

// The quadruped with its configured gait, advanced `seconds`.
std::unique_ptr<yamor::bridge::Robot> Quadruped(double seconds) {
  auto robot = std::make_unique<yamor::bridge::Robot>(yamor::physics::Morphology::LoadFile(
      std::string(YAMOR_SOURCE_DIR) + "/configs/worlds/quadruped.xml"));
  std::vector<yamor::snp::Frame> out;
  const auto config =
      yamor::cpg::LoadConfigFile(std::string(YAMOR_SOURCE_DIR) + "/configs/robots/quadruped.xml");
  for (const yamor::snp::Frame& frame : yamor::host::ConfigurationFrames(config)) {
    robot->HandleFrame(frame, out);
  }
  robot->Advance(seconds, out);
  return robot;
}

struct Rate {
  double render_fps = 0;     // render only, wall clock
  double png_fps = 0;        // render + fast PNG, wall clock
  double render_cpu_ms = 0;  // CPU per frame (all threads), render only
  double png_cpu_ms = 0;     // CPU per frame, render + PNG
  double png_kib = 0;        // mean PNG size
};

Rate Measure(Renderer& renderer, const Scene& scene, const Camera& camera, int w, int h,
             int frames) {
  renderer.Render(scene, camera, w, h);  // warm-up: buffers, shader compilation
  Rate rate;
  auto start = std::chrono::steady_clock::now();
  double cpu = ProcessCpuSeconds();
  for (int i = 0; i < frames; ++i) renderer.Render(scene, camera, w, h);
  rate.render_cpu_ms = (ProcessCpuSeconds() - cpu) * 1e3 / frames;
  rate.render_fps =
      frames / std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::size_t bytes = 0;
  start = std::chrono::steady_clock::now();
  cpu = ProcessCpuSeconds();
  for (int i = 0; i < frames; ++i) {
    bytes += yamor::render::EncodePng(renderer.Render(scene, camera, w, h), true).size();
  }
  rate.png_cpu_ms = (ProcessCpuSeconds() - cpu) * 1e3 / frames;
  rate.png_fps =
      frames / std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  rate.png_kib = static_cast<double>(bytes) / frames / 1024.0;
  return rate;
}

double Median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n == 0 ? 0.0 : n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

struct VideoCost {
  double frames_cpu = 0;  // this process: rendering (+ PNG), the simulation left out
  double render_cpu = 0;  // of which Render() alone
  double ffmpeg_cpu = 0;  // the ffmpeg child
  bool video = false;     // ffmpeg ran
};

// 500 frames of the quadruped walking from t = 0, 0.04 s apart, into an
// MP4: PNG frames (`raw` false) or raw RGBA frames.
VideoCost MakeVideo(Renderer& renderer, const Camera& camera, bool raw,
                    const std::string& yuv_path = {}) {
  auto robot = Quadruped(0.0);
  std::vector<yamor::snp::Frame> out;
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("render_bench_" + std::to_string(getpid()) + ".mp4"))
                               .string();
  VideoCost cost;
  std::ofstream yuv_out;
  if (!yuv_path.empty()) yuv_out.open(yuv_path, std::ios::binary | std::ios::trunc);
  std::vector<uint8_t> yuv;
  const double children_start = ChildrenCpuSeconds();
  yamor::render::VideoResult video;
  yamor::render::Image image;  // raw frames: one buffer, as a filmed Evaluate keeps
  {
    yamor::render::VideoOptions options{.frame_rate = 25};
    if (raw) {
      options.raw_width = 320;
      options.raw_height = 240;
    }
    yamor::render::VideoWriter writer(path, options);
    for (int i = 0; i < 500; ++i) {
      const double t0 = ProcessCpuSeconds();
      if (raw) {
        renderer.RenderInto(yamor::bridge::SceneOf(robot->world()), camera, 320, 240, {}, image);
      } else {
        image = renderer.Render(yamor::bridge::SceneOf(robot->world()), camera, 320, 240);
      }
      cost.render_cpu += ProcessCpuSeconds() - t0;
      if (raw) {
        writer.AddImage(image);
      } else {
        writer.AddFrame(yamor::render::EncodePng(image, true));
      }
      cost.frames_cpu += ProcessCpuSeconds() - t0;
      if (yuv_out.is_open()) {
        yamor::render::RgbaToYuv420(image, yuv);
        yuv_out.write(reinterpret_cast<const char*>(yuv.data()),
                      static_cast<std::streamsize>(yuv.size()));
      }
      robot->Advance(0.04, out);
    }
    video = writer.Finish();
  }
  cost.ffmpeg_cpu = ChildrenCpuSeconds() - children_start;
  cost.video = video.video;
  std::filesystem::remove(path);
  if (!video.video) {
    for (int i = 0; i < video.frames; ++i) {
      std::filesystem::remove(fmt::format("{}-{:06d}.png", path.substr(0, path.size() - 4), i));
    }
  }
  return cost;
}

void WritePng(const std::string& path, const yamor::render::Image& image) {
  const std::vector<uint8_t> png = yamor::render::EncodePng(image);
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
}

}  // namespace

int main(int argc, char** argv) {
  // As yamord does: one rasteriser thread unless LP_NUM_THREADS is set
  // (LP_NUM_THREADS=2 measures llvmpipe's default on this machine's 2 cores).
  const bool one_raster_thread = yamor::render::DefaultToOneRasterThread();
  CLI::App app{"render_bench: headless rendering cost (docs/benchmarks.md)"};
  app.footer(
      "LP_NUM_THREADS: llvmpipe's rasteriser threads per GL context; render_bench, like yamord,\n"
      "sets 0 (rasterise on the calling thread) unless it is set.");
  int frames = 40;
  std::string png_dir;
  std::string backend_name = "auto";
  int runs = 5;
  bool video_only = false;
  app.add_option("--frames", frames, "Frames per measurement");
  app.add_option("--runs", runs, "Runs of the 20-s video measurement (medians)")->check(CLI::PositiveNumber);
  app.add_flag("--video-only", video_only, "Only the 20-s video measurement");
  bool no_video = false;
  app.add_flag("--no-video", no_video, "Leave out the 20-s video measurement");
  bool breakdown = false;
  app.add_flag("--breakdown", breakdown, "Also the CPU per frame with each part switched off");
  app.add_option("--png", png_dir, "Also write sample frames into this directory");
  std::string yuv_path;
  app.add_option("--yuv", yuv_path, "Also write the raw video's frames (yuv420p) to this file");
  app.add_option("--backend", backend_name, "auto, osmesa or egl")
      ->check(CLI::IsMember({"auto", "osmesa", "egl"}));
  CLI11_PARSE(app, argc, argv);
  yamor::SetLogLevel("warn");
  const yamor::render::Backend backend = backend_name == "osmesa" ? yamor::render::Backend::kOsMesa
                                         : backend_name == "egl"  ? yamor::render::Backend::kEgl
                                                                  : yamor::render::Backend::kAuto;
  Renderer renderer(backend);
  std::printf("renderer: %s\nLP_NUM_THREADS=%s%s\n\n", renderer.description().c_str(),
              std::getenv(yamor::render::kRasterThreadsVariable),
              one_raster_thread ? " (render_bench's default)" : " (set by the user)");

  const auto quadruped = Quadruped(8.0);
  yamor::bridge::Robot snake(SnakeMorphology(64));
  struct Case {
    const char* name;
    Scene scene;
    Camera camera;
  };
  Camera follow;
  Camera snake_view;
  snake_view.distance = 4.0;
  snake_view.elevation = 0.6;
  std::vector<Case> cases = {{"quadruped", yamor::bridge::SceneOf(quadruped->world()), follow},
                             {"snake64", yamor::bridge::SceneOf(snake.world()), snake_view}};

  if (!video_only) {
    std::printf("%-10s %-8s %11s %15s %14s %18s %8s\n", "robot", "size", "render fps",
                "render+png fps", "render CPU ms", "render+png CPU ms", "png KiB");
  }
  for (const Case& c : cases) {
    if (video_only) break;
    for (auto [w, h] : {std::pair{320, 240}, std::pair{640, 480}}) {
      const Rate r = Measure(renderer, c.scene, c.camera, w, h, frames);
      std::printf("%-10s %-8s %11.1f %15.1f %14.2f %18.2f %8.1f\n", c.name,
                  fmt::format("{}x{}", w, h).c_str(), r.render_fps, r.png_fps, r.render_cpu_ms,
                  r.png_cpu_ms, r.png_kib);
    }
  }

  if (breakdown) {
    // What each part of a frame costs: the quadruped at 320x240 with one
    // part switched off at a time (CPU ms per frame, median of 5 batches).
    struct Part {
      const char* name;
      yamor::render::RenderOptions options;
    };
    const std::vector<Part> parts = {
        {"everything", {}},
        {"no grid", {.grid = false}},
        {"no edges", {.edges = false}},
        {"no shadows", {.shadows = false}},
        {"no lighting", {.lighting = false}},
        {"no labels, no legend", {.labels = false, .legend = false}},
        {"none of these",
         {.lighting = false, .edges = false, .grid = false, .shadows = false, .labels = false,
          .legend = false}},
    };
    std::printf("\nquadruped 320x240, CPU ms per frame:\n");
    for (const Part& part : parts) {
      std::vector<double> batches;
      for (int b = 0; b < 5; ++b) {
        const double cpu = ProcessCpuSeconds();
        for (int i = 0; i < frames; ++i) renderer.Render(cases[0].scene, follow, 320, 240, part.options);
        batches.push_back((ProcessCpuSeconds() - cpu) * 1e3 / frames);
      }
      std::printf("  %-22s %6.2f\n", part.name, Median(batches));
    }
  }

  // A 20-s video at 25 fps of the 20-s evaluation it shows (quadruped),
  // `runs` times: the evaluation alone, then the video made two ways (PNG
  // frames piped to ffmpeg as RecordFrames' clients do; raw RGBA frames piped
  // to ffmpeg as an in-process writer can). Medians over the runs; each
  // run's ratio is against the evaluation measured in the same run.
  std::vector<double> eval_cpus, png_frames, png_ffmpeg, png_ratio, raw_frames, raw_render,
      raw_ffmpeg, raw_ratio;
  bool made_video = true;
  for (int run = 0; run < (no_video ? 0 : runs); ++run) {
    const double eval_cpu_start = ProcessCpuSeconds();
    const auto evaluated = Quadruped(20.0);
    const double eval_cpu = ProcessCpuSeconds() - eval_cpu_start;
    eval_cpus.push_back(eval_cpu);
    for (const bool raw : {false, true}) {
      const VideoCost cost = MakeVideo(renderer, follow, raw);
      made_video = made_video && cost.video;
      (raw ? raw_frames : png_frames).push_back(cost.frames_cpu);
      if (raw) raw_render.push_back(cost.render_cpu);
      (raw ? raw_ffmpeg : png_ffmpeg).push_back(cost.ffmpeg_cpu);
      (raw ? raw_ratio : png_ratio).push_back((cost.frames_cpu + cost.ffmpeg_cpu) / eval_cpu);
    }
  }
  if (!no_video) {
    std::printf("\n20-s quadruped video, 25 fps, 320x240 (500 frames), median of %d runs:\n", runs);
    std::printf("  evaluation alone (20 s simulated)      %7.2f s CPU\n", Median(eval_cpus));
    std::printf("  PNG frames: render + PNG               %7.2f s CPU\n", Median(png_frames));
    std::printf("  PNG frames: ffmpeg (H.264)             %7.2f s CPU%s\n", Median(png_ffmpeg),
                made_video ? "" : " (no ffmpeg: PNG sequence)");
    std::printf("  PNG frames: video cost / evaluation    %7.2fx\n", Median(png_ratio));
    std::printf("  raw frames: render + YUV + pipe        %7.2f s CPU\n", Median(raw_frames));
    std::printf("    of which render                      %7.2f s CPU\n", Median(raw_render));
    std::printf("  raw frames: ffmpeg (H.264)             %7.2f s CPU\n", Median(raw_ffmpeg));
    std::printf("  raw frames: video cost / evaluation    %7.2fx\n", Median(raw_ratio));
  }
  if (!yuv_path.empty()) {
    MakeVideo(renderer, follow, /*raw=*/true, yuv_path);
    std::printf("\nthe raw video's frames (yuv420p 320x240, 25 fps) in %s\n", yuv_path.c_str());
  }
  if (!png_dir.empty()) {
    std::filesystem::create_directories(png_dir);
    Camera top;
    top.kind = CameraKind::kTop;
    const auto evaluated = Quadruped(20.0);
    const Scene walked = yamor::bridge::SceneOf(evaluated->world());
    top.target = walked.Central()->body.position;
    top.target.z() = 0;
    top.height = 1.2;
    WritePng(png_dir + "/quadruped_follow.png", renderer.Render(cases[0].scene, follow, 640, 480));
    WritePng(png_dir + "/quadruped_follow_320.png",
             renderer.Render(cases[0].scene, follow, 320, 240));
    WritePng(png_dir + "/quadruped_top.png", renderer.Render(walked, top, 640, 480));
    WritePng(png_dir + "/snake64.png", renderer.Render(cases[1].scene, snake_view, 640, 480));
    std::printf("\nsample frames in %s\n", png_dir.c_str());
  }
  return 0;
}
