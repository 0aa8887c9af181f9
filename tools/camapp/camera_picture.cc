#include "tools/camapp/camera_picture.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "common/format.h"
#include "common/log.h"
#include "common/status.h"

namespace yamor::camapp {

CameraPicture::CameraPicture(const CameraEmulator& camera, int max_side) {
  const CameraOptions& o = camera.options();
  const host::LensModel& lens = camera.lens();
  width_ = o.width;
  height_ = o.height;
  // How far from the principal point the image border reaches once undistorted.
  double reach_x = 0.0;
  double reach_y = 0.0;
  auto reach = [&](double u, double v) {
    const Eigen::Vector2d ideal = lens.Undistort({u, v});
    reach_x = std::max(reach_x, std::fabs(ideal.x() - o.cx));
    reach_y = std::max(reach_y, std::fabs(ideal.y() - o.cy));
  };
  for (int u = 0; u < width_; ++u) {
    reach(u, 0);
    reach(u, height_ - 1);
  }
  for (int v = 0; v < height_; ++v) {
    reach(0, v);
    reach(width_ - 1, v);
  }
  const int half_w = static_cast<int>(std::ceil(reach_x)) + 2;
  const int half_h = static_cast<int>(std::ceil(reach_y)) + 2;
  if (2 * half_w > max_side || 2 * half_h > max_side) {
    throw Error(StatusCode::kInvalidArgument,
                fmt::format("camera picture: the lens needs a {}x{} render, above the {}-pixel cap",
                            2 * half_w, 2 * half_h, max_side));
  }
  request_.width = 2 * half_w;
  request_.height_px = 2 * half_h;
  request_.target = Eigen::Vector3d(o.camera_x, o.camera_y, 0.0);
  request_.height = o.camera_height;
  // The render's focal length equals the camera's (square pixels).
  request_.fov = 2.0 * std::atan(request_.height_px / (2.0 * o.focal));
  const Eigen::Vector2d shift(0.5 * (request_.width - 1) - o.cx, 0.5 * (request_.height_px - 1) - o.cy);
  source_.resize(static_cast<size_t>(width_) * height_);
  for (int v = 0; v < height_; ++v) {
    for (int u = 0; u < width_; ++u) {
      source_[static_cast<size_t>(v) * width_ + u] = (lens.Undistort({u, v}) + shift).cast<float>();
    }
  }
}

render::Image CameraPicture::Distort(const render::Image& pinhole) const {
  if (pinhole.width != request_.width || pinhole.height != request_.height_px ||
      pinhole.rgba.size() != static_cast<size_t>(pinhole.width) * pinhole.height * 4) {
    throw Error(StatusCode::kInvalidArgument,
                fmt::format("camera picture: expected a {}x{} render, got {}x{}", request_.width,
                            request_.height_px, pinhole.width, pinhole.height));
  }
  render::Image out;
  out.width = width_;
  out.height = height_;
  out.rgba.resize(static_cast<size_t>(width_) * height_ * 4);
  const int max_x = pinhole.width - 1;
  const int max_y = pinhole.height - 1;
  for (size_t i = 0; i < source_.size(); ++i) {
    const float x = std::clamp(source_[i].x(), 0.0f, static_cast<float>(max_x));
    const float y = std::clamp(source_[i].y(), 0.0f, static_cast<float>(max_y));
    const int x0 = std::min(static_cast<int>(x), max_x);
    const int y0 = std::min(static_cast<int>(y), max_y);
    const int x1 = std::min(x0 + 1, max_x);
    const int y1 = std::min(y0 + 1, max_y);
    const float fx = x - x0;
    const float fy = y - y0;
    auto at = [&](int px, int py, int c) {
      return static_cast<float>(pinhole.rgba[(static_cast<size_t>(py) * pinhole.width + px) * 4 + c]);
    };
    for (int c = 0; c < 4; ++c) {
      const float top = at(x0, y0, c) * (1 - fx) + at(x1, y0, c) * fx;
      const float bottom = at(x0, y1, c) * (1 - fx) + at(x1, y1, c) * fx;
      out.rgba[i * 4 + c] = static_cast<uint8_t>(std::lround(top * (1 - fy) + bottom * fy));
    }
  }
  return out;
}

void CameraPicture::MarkPixel(render::Image& picture, const Eigen::Vector2d& pixel, int radius,
                              std::array<uint8_t, 3> rgb) {
  const int cx = static_cast<int>(std::lround(pixel.x()));
  const int cy = static_cast<int>(std::lround(pixel.y()));
  auto paint = [&](int x, int y) {
    if (x < 0 || y < 0 || x >= picture.width || y >= picture.height) return;
    uint8_t* p = &picture.rgba[(static_cast<size_t>(y) * picture.width + x) * 4];
    p[0] = rgb[0];
    p[1] = rgb[1];
    p[2] = rgb[2];
    p[3] = 255;
  };
  for (int d = -radius; d <= radius; ++d) {
    if (std::abs(d) < 2) continue;  // leave the LED itself visible
    paint(cx + d, cy);
    paint(cx, cy + d);
  }
}

PictureRecorder::PictureRecorder(const CameraEmulator& camera, std::filesystem::path folder, int every,
                                 PinholeRenderer renderer)
    : picture_(camera),
      camera_(camera),
      folder_(std::move(folder)),
      every_(every),
      renderer_(std::move(renderer)) {
  if (every_ < 1) {
    throw Error(StatusCode::kInvalidArgument,
                "camera pictures: every must be at least 1, got " + std::to_string(every_));
  }
  std::error_code error;
  std::filesystem::create_directories(folder_, error);
  if (error || !std::filesystem::is_directory(folder_)) {
    throw Error(StatusCode::kInvalidArgument,
                "camera pictures: cannot create the folder " + folder_.string() + ": " + error.message());
  }
  index_.open(folder_ / "frames.csv", std::ios::binary | std::ios::trunc);
  if (!index_) {
    throw Error(StatusCode::kInvalidArgument,
                "camera pictures: cannot write " + (folder_ / "frames.csv").string());
  }
  index_ << "seq,camera_time_us,picture_time,state,pixel_x,pixel_y,file\n" << std::flush;
  thread_ = std::thread([this] { Loop(); });
}

PictureRecorder::~PictureRecorder() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  changed_.notify_all();
  thread_.join();
}

void PictureRecorder::Offer(const CapturedFrame& frame) {
  if (offered_++ % static_cast<std::uint64_t>(every_) != 0) return;
  {
    std::lock_guard lock(mutex_);
    if (waiting_) ++skipped_;
    waiting_ = frame;
  }
  changed_.notify_all();
}

void PictureRecorder::Drain() {
  std::unique_lock lock(mutex_);
  changed_.wait(lock, [this] { return !waiting_ && !busy_; });
}

std::uint64_t PictureRecorder::written() const {
  std::lock_guard lock(mutex_);
  return written_;
}

std::uint64_t PictureRecorder::skipped() const {
  std::lock_guard lock(mutex_);
  return skipped_;
}

std::uint64_t PictureRecorder::failed() const {
  std::lock_guard lock(mutex_);
  return failed_;
}

void PictureRecorder::Loop() {
  std::unique_lock lock(mutex_);
  while (true) {
    changed_.wait(lock, [this] { return stop_ || waiting_.has_value(); });
    if (!waiting_) return;  // stopping, nothing left
    const CapturedFrame frame = *waiting_;
    waiting_.reset();
    busy_ = true;
    lock.unlock();
    bool ok = true;
    try {
      Write(frame);
    } catch (const std::exception& e) {
      ok = false;
      Log().warn("camapp: no picture of frame {}: {}", frame.seq, e.what());
    }
    lock.lock();
    busy_ = false;
    ++(ok ? written_ : failed_);
    changed_.notify_all();
  }
}

void PictureRecorder::Write(const CapturedFrame& frame) {
  const auto [png, picture_time] = renderer_(picture_.request());
  render::Image image = picture_.Distort(render::DecodePng(png));
  const bool seen = frame.frame.state == FrameState::kSeen;
  if (seen) {
    CameraPicture::MarkPixel(image, frame.frame.pixel, 9, {40, 220, 60});
  } else if (frame.frame.state != FrameState::kOutside) {
    CameraPicture::MarkPixel(image, frame.frame.exact, 9, {230, 160, 20});  // there, but not seen
  }
  const std::string name = fmt::format("frame-{:06d}.png", frame.seq);
  const std::vector<uint8_t> bytes = render::EncodePng(image, /*fast=*/true);
  const std::filesystem::path path = folder_ / name;
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  out.close();
  if (!out) throw Error(StatusCode::kInvalidArgument, "cannot write " + path.string());
  index_ << fmt::format("{},{},{},{},{},{},{}\n", frame.seq, frame.time_us, FormatDouble(picture_time),
                        FrameStateName(frame.frame.state), seen ? camera_.PixelText(frame.frame.pixel.x()) : "",
                        seen ? camera_.PixelText(frame.frame.pixel.y()) : "", name)
         << std::flush;
}

}  // namespace yamor::camapp
