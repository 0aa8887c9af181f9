// How many threads llvmpipe (Mesa's software rasteriser, behind both the
// OSMesa and the EGL backend) rasterises with. By default it starts one
// rasteriser thread per core for every GL context, and the rendering thread
// hands each frame to them and waits; yamor's frames are small (320x240 to
// 640x480) and its renderers already run one per thread in parallel, so the
// hand-over costs more CPU than it saves (docs/benchmarks.md, "Rendering").
// LP_NUM_THREADS=0 makes llvmpipe rasterise on the calling thread. llvmpipe
// reads the variable once, when the first context is made, and setenv() is
// not safe while other threads may read the environment: so the programs
// that render in-process (yamord, render_bench) call
// DefaultToOneRasterThread() first thing in main(), before any thread starts.
#pragma once

#include <optional>
#include <string>

namespace yamor::render {

/// The environment variable llvmpipe reads for its rasteriser thread count.
inline constexpr char kRasterThreadsVariable[] = "LP_NUM_THREADS";

/// The value to give LP_NUM_THREADS when its current value is `current`
/// (nullptr: unset): "0" (rasterise on the rendering thread) when unset,
/// nullopt when the user has set it (to anything, even empty): their choice stands.
/// Thread-safety: pure function.
std::optional<std::string> RasterThreadsToSet(const char* current);

/// Sets LP_NUM_THREADS to RasterThreadsToSet(its value), i.e. to "0" unless
/// the user has set it; returns true when it set it. Call at the top of
/// main(), before any thread starts and before the first Renderer.
/// Thread-safety: not thread-safe (setenv): only while the process has one thread.
bool DefaultToOneRasterThread();

}  // namespace yamor::render
