#include "physics/render/image.h"

#include <png.h>

#include <cstring>
#include <string>

#include "common/status.h"

namespace yamor::render {
namespace {

// DecodePng refuses larger images (a few bytes could claim gigabytes).
constexpr png_uint_32 kMaxDecodedSide = 16384;

}  // namespace

std::array<uint8_t, 4> Image::At(int x, int y) const {
  YAMOR_CHECK(x >= 0 && x < width && y >= 0 && y < height, "Image::At outside the image");
  const std::size_t i = (static_cast<std::size_t>(y) * width + x) * 4;
  return {rgba[i], rgba[i + 1], rgba[i + 2], rgba[i + 3]};
}

std::vector<uint8_t> EncodePng(const Image& image, bool fast) {
  if (image.width <= 0 || image.height <= 0 ||
      image.rgba.size() != static_cast<std::size_t>(image.width) * image.height * 4) {
    throw Error(StatusCode::kInvalidArgument,
                "EncodePng: image " + std::to_string(image.width) + "x" +
                    std::to_string(image.height) + " holds " + std::to_string(image.rgba.size()) +
                    " bytes, not width*height*4");
  }
  const std::size_t pixels = static_cast<std::size_t>(image.width) * image.height;
  bool opaque = true;
  for (std::size_t i = 0; i < pixels && opaque; ++i) opaque = image.rgba[i * 4 + 3] == 255;
  std::vector<uint8_t> rgb;
  const void* source = image.rgba.data();
  if (opaque) {  // a third smaller and faster to compress
    rgb.resize(pixels * 3);
    for (std::size_t i = 0; i < pixels; ++i) std::memcpy(&rgb[i * 3], &image.rgba[i * 4], 3);
    source = rgb.data();
  }
  png_image png;
  std::memset(&png, 0, sizeof(png));
  png.version = PNG_IMAGE_VERSION;
  png.width = static_cast<png_uint_32>(image.width);
  png.height = static_cast<png_uint_32>(image.height);
  png.format = opaque ? PNG_FORMAT_RGB : PNG_FORMAT_RGBA;
  if (fast) png.flags |= PNG_IMAGE_FLAG_FAST;
  // One pass into a buffer of the worst-case size.
  png_alloc_size_t size = PNG_IMAGE_PNG_SIZE_MAX(png);
  std::vector<uint8_t> out(size);
  if (!png_image_write_to_memory(&png, out.data(), &size, 0, source, 0, nullptr)) {
    const std::string reason = png.message;
    png_image_free(&png);
    throw Error(StatusCode::kInternal, "EncodePng: libpng: " + reason);
  }
  out.resize(size);
  return out;
}

Image DecodePng(std::span<const uint8_t> bytes) {
  png_image png;
  std::memset(&png, 0, sizeof(png));
  png.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_memory(&png, bytes.data(), bytes.size())) {
    const std::string reason = png.message;
    png_image_free(&png);
    throw Error(StatusCode::kInvalidArgument, "not a PNG image: " + reason);
  }
  if (png.width > kMaxDecodedSide || png.height > kMaxDecodedSide) {
    png_image_free(&png);
    throw Error(StatusCode::kInvalidArgument,
                "PNG image " + std::to_string(png.width) + "x" + std::to_string(png.height) +
                    " is larger than " + std::to_string(kMaxDecodedSide) + " pixels a side");
  }
  png.format = PNG_FORMAT_RGBA;
  Image image;
  image.width = static_cast<int>(png.width);
  image.height = static_cast<int>(png.height);
  image.rgba.resize(PNG_IMAGE_SIZE(png));
  if (!png_image_finish_read(&png, nullptr, image.rgba.data(), 0, nullptr)) {
    const std::string reason = png.message;
    png_image_free(&png);
    throw Error(StatusCode::kInvalidArgument, "bad PNG image: " + reason);
  }
  return image;
}

}  // namespace yamor::render
