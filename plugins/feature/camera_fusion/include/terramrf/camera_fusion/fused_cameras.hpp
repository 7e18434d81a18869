#pragma once
// What the image features (haralick, homogeneity, colour) share: finding the fused cameras of a
// frame, choosing the camera per cell, and a grey view of an image. Header-only so each feature
// stays one self-contained plugin library.
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "terramrf/plugin.hpp"

namespace terramrf::fusion {

/// Declares the two parameters every image feature has: `camera` (which fused camera) and
/// `min_pixels` (fewer pixels in a cell give NaN; `least` is the feature's own lower bound).
inline void declareCameraChoice(ParamDecl& d, int& camera, int& min_pixels, int least) {
  d.add("camera", camera,
        "index into the frame's cameras; −1: per cell the fused camera that sees it with the "
        "most pixels")
      .unit("index")
      .range(-1, 64);
  d.add("min_pixels", min_pixels, "cells with fewer pixels get NaN")
      .unit("px")
      .range(least, 1 << 22);
}

struct FusedCamera {
  const CellPixels* pixels = nullptr;
  const Image* image = nullptr;
  std::string file;  ///< image file (or frame) for messages
};

/// The fused cameras a feature reads: `camera` ≥ 0 selects Frame::cameras[camera], −1 takes every
/// fused camera. Throws InputError naming the frame if `camera` is not one of its cameras (listing
/// them) or is not fused (no camera_fusion stage ran for it), and naming the image if an image is
/// missing or its size differs from the fusion's.
inline std::vector<FusedCamera> fusedCameras(const FrameContext& ctx, int camera,
                                             const std::string& stage) {
  const Frame& f = *ctx.frame;
  const std::string frame_file = f.source_path.empty() ? "frame " + f.id : f.source_path;
  // Told apart from "not fused": running camera_fusion first would not help an index the frame
  // does not have, and the list shows which index is meant.
  if (camera >= 0 && std::size_t(camera) >= f.cameras.size()) {
    std::string have;
    for (std::size_t i = 0; i < f.cameras.size(); ++i)
      have += (i ? ", " : "") + std::to_string(i) + " '" + f.cameras[i].model.name + "'";
    throw InputError(frame_file, stage + ": camera " + std::to_string(camera) +
                                     " is beyond frame " + f.id + "'s cameras; it has " +
                                     std::to_string(f.cameras.size()) +
                                     (f.cameras.empty() ? "" : " (" + have + ")") +
                                     "; expected camera: an index among them, or −1 for all");
  }
  std::vector<FusedCamera> out;
  for (const CellPixels& cp : ctx.grid->cellPixels()) {
    if (camera >= 0 && cp.camera != camera) continue;
    if (cp.camera < 0 || std::size_t(cp.camera) >= f.cameras.size())
      throw InputError(frame_file, "fused pixels refer to camera " + std::to_string(cp.camera) +
                                       " but frame " + f.id + " has " +
                                       std::to_string(f.cameras.size()) + " cameras");
    const CameraImage& cam = f.cameras[cp.camera];
    FusedCamera fc;
    fc.pixels = &cp;
    fc.file = cam.source_path.empty() ? "frame " + f.id : cam.source_path;
    if (!cam.image || cam.image->empty())
      throw InputError(fc.file, stage + " needs the camera image; frame " + f.id + " has none");
    if (cam.image->width != cp.width || cam.image->height != cp.height)
      throw InputError(fc.file, "image is " + std::to_string(cam.image->width) + "x" +
                                    std::to_string(cam.image->height) +
                                    " px but the fused pixels are for " + std::to_string(cp.width) +
                                    "x" + std::to_string(cp.height));
    if (cam.image->channels != 1 && cam.image->channels != 3)
      throw InputError(fc.file, "image has " + std::to_string(cam.image->channels) +
                                    " channels; expected 1 (grey) or 3 (RGB)");
    fc.image = cam.image.get();
    out.push_back(fc);
  }
  if (out.empty())
    throw InputError(frame_file,
                     stage + ": no fused pixels for " +
                         (camera >= 0 ? "camera " + std::to_string(camera) : "any camera") +
                         " in frame " + f.id + "; run a camera_fusion stage before it");
  return out;
}

/// Camera to read cell `cell` from: the one in which it covers the most pixels (first on ties);
/// −1 if it has no pixels in any.
inline int bestCamera(const std::vector<FusedCamera>& cams, int cell) {
  int best = -1;
  uint32_t most = 0;
  for (std::size_t k = 0; k < cams.size(); ++k) {
    const uint32_t n = cams[k].pixels->count(cell);
    if (n > most) most = n, best = int(k);
  }
  return best;
}

/// Zero-copy cv::Mat view of an Image (RGB order).
inline cv::Mat matView(const Image& img) {
  return cv::Mat(img.height, img.width, img.channels == 3 ? CV_8UC3 : CV_8UC1,
                 const_cast<uint8_t*>(img.data.data()));
}

/// 8-bit grey: OpenCV's luma Y = 0.299 R + 0.587 G + 0.114 B (rounded); 1-channel images as they
/// are. Rows [row0, row1) only when given (each pixel converts alone, so the same values as
/// those rows of the whole image). `out` is reused between frames.
inline void toGrey(const Image& img, cv::Mat& out, int row0 = 0, int row1 = -1) {
  const cv::Mat in = matView(img).rowRange(row0, row1 < 0 ? img.height : row1);
  if (img.channels == 3)
    cv::cvtColor(in, out, cv::COLOR_RGB2GRAY);
  else
    in.copyTo(out);
}

}  // namespace terramrf::fusion
