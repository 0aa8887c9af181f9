#include "physics/render/raster_threads.h"

#include <cstdlib>

namespace yamor::render {

std::optional<std::string> RasterThreadsToSet(const char* current) {
  if (current != nullptr) return std::nullopt;
  return std::string("0");
}

bool DefaultToOneRasterThread() {
  const std::optional<std::string> value = RasterThreadsToSet(std::getenv(kRasterThreadsVariable));
  if (!value) return false;
  // overwrite = 0: should the variable appear in between, the user's value still wins.
  return ::setenv(kRasterThreadsVariable, value->c_str(), 0) == 0;
}

}  // namespace yamor::render
