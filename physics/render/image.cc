#include "physics/render/image.h"

#include <png.h>

#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <string>

#include "common/status.h"

namespace yamor::render {
namespace {

// DecodePng refuses larger images (a few bytes could claim gigabytes).
constexpr png_uint_32 kMaxDecodedSide = 16384;

// libpng's write callback into a byte vector.
void AppendToVector(png_structp png, png_bytep data, png_size_t length) {
  auto* out = static_cast<std::vector<uint8_t>*>(png_get_io_ptr(png));
  out->insert(out->end(), data, data + length);
}

void IgnoreFlush(png_structp) {}

// The message of libpng's last error on this thread (set before it jumps).
thread_local char png_error_message[256];

[[noreturn]] void JumpOnPngError(png_structp png, png_const_charp message) {
  std::snprintf(png_error_message, sizeof(png_error_message), "%s", message);
  png_longjmp(png, 1);
}

void IgnorePngWarning(png_structp, png_const_charp) {}

// The rows of a fast PNG into `png`'s output; false when libpng failed
// (message in png_error_message). Holds no object with a destructor: libpng
// reports errors by longjmp back to the setjmp here.
bool WriteFastPngRows(png_structp png, png_infop info, const uint8_t* pixels, int width,
                      int height, bool opaque) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_set_IHDR(png, info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height), 8,
               opaque ? PNG_COLOR_TYPE_RGB : PNG_COLOR_TYPE_RGBA, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_set_compression_level(png, 1);
  png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_NONE);
  png_write_info(png, info);
  const std::size_t stride = static_cast<std::size_t>(width) * (opaque ? 3 : 4);
  for (int y = 0; y < height; ++y) {
    png_write_row(png, const_cast<png_bytep>(pixels + static_cast<std::size_t>(y) * stride));
  }
  png_write_end(png, nullptr);
  return true;
}

// Video frames: libpng's low-level writer at zlib level 1 without row
// filters instead of the simplified API's fast setting (level 3, no
// filter, with its own row copies): about 20 % less CPU for about 25 % more
// bytes on rendered frames (docs/benchmarks.md, "Rendering"). The SUB and UP
// filters and zlib's RLE strategy were slower or much larger.
std::vector<uint8_t> EncodeFastPng(const uint8_t* pixels, int width, int height, bool opaque) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, JumpOnPngError,
                                            IgnorePngWarning);
  if (png == nullptr) throw Error(StatusCode::kInternal, "EncodePng: libpng: out of memory");
  png_infop info = png_create_info_struct(png);
  std::vector<uint8_t> out;
  out.reserve(static_cast<std::size_t>(width) * height / 2 + 1024);
  bool ok = info != nullptr;
  if (ok) {
    png_set_write_fn(png, &out, AppendToVector, IgnoreFlush);
    ok = WriteFastPngRows(png, info, pixels, width, height, opaque);
  }
  png_destroy_write_struct(&png, info != nullptr ? &info : nullptr);
  if (!ok) {
    throw Error(StatusCode::kInternal,
                std::string("EncodePng: libpng: ") + (info ? png_error_message : "out of memory"));
  }
  return out;
}

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
  if (fast) {
    return EncodeFastPng(static_cast<const uint8_t*>(source), image.width, image.height, opaque);
  }
  png_image png;
  std::memset(&png, 0, sizeof(png));
  png.version = PNG_IMAGE_VERSION;
  png.width = static_cast<png_uint_32>(image.width);
  png.height = static_cast<png_uint_32>(image.height);
  png.format = opaque ? PNG_FORMAT_RGB : PNG_FORMAT_RGBA;
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
