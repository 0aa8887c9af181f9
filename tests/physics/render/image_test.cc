// PNG encoding of images: decoding gives the buffer back, bytes are stable.
#include "physics/render/image.h"

#include <gtest/gtest.h>

#include <random>

#include "common/status.h"

namespace yamor::render {
namespace {

Image Noise(int width, int height, bool opaque, uint64_t seed) {
  std::mt19937_64 rng(seed);
  Image image{.width = width, .height = height};
  image.rgba.resize(static_cast<std::size_t>(width) * height * 4);
  for (std::size_t i = 0; i < image.rgba.size(); ++i) {
    image.rgba[i] = (opaque && i % 4 == 3) ? 255 : static_cast<uint8_t>(rng());
  }
  return image;
}

TEST(PngTest, DecodingGivesTheImageBackOpaqueOrNot) {
  for (bool opaque : {true, false}) {
    for (bool fast : {false, true}) {
      const Image image = Noise(37, 23, opaque, 7);
      const std::vector<uint8_t> png = EncodePng(image, fast);
      ASSERT_GT(png.size(), 8u);
      EXPECT_EQ(png[1], 'P');
      EXPECT_TRUE(DecodePng(png) == image) << "opaque " << opaque << " fast " << fast;
      EXPECT_EQ(EncodePng(image, fast), png);  // deterministic
    }
  }
}

TEST(PngTest, OpaqueImagesAreStoredAsRgb) {
  const std::vector<uint8_t> png = EncodePng(Noise(4, 4, true, 1));
  ASSERT_GT(png.size(), 26u);
  EXPECT_EQ(png[25], 2);  // IHDR colour type: truecolour without alpha
  EXPECT_EQ(EncodePng(Noise(4, 4, false, 1))[25], 6);  // with alpha
}

TEST(PngTest, BadInputIsRefused) {
  Image inconsistent{.width = 3, .height = 3};
  inconsistent.rgba.resize(5);
  EXPECT_THROW(EncodePng(inconsistent), Error);
  const std::vector<uint8_t> junk = {1, 2, 3, 4, 5, 6, 7, 8, 9};
  try {
    DecodePng(junk);
    ADD_FAILURE() << "junk decoded";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kInvalidArgument);
  }
  std::vector<uint8_t> truncated = EncodePng(Noise(16, 16, true, 2));
  truncated.resize(truncated.size() / 2);
  EXPECT_THROW(DecodePng(truncated), Error);
}

}  // namespace
}  // namespace yamor::render
