#pragma once
// Sparse z-buffer of one camera image built from the LiDAR points' pixels, for camera_fusion's
// depth test: what is nearest to the camera at a pixel, and which grid cell it belongs to.
#include <cstdint>
#include <cstring>
#include <vector>

namespace terramrf {

/// Per pixel the nearest projected point's depth and cell. The scan is sparse in the image (rings
/// a few pixels apart), so each point is splatted over the (2·splat_px + 1)² square around its
/// pixel, keeping the nearest: a surface between its rings still hides what is behind it.
///
/// Depth is the homogeneous coordinate w of P · T_camera_lidar · [X; 1] (the camera z for
/// P = K [I | 0]; KITTI's P2 adds 5 mm), the quantity whose inverse is affine in (u, v) over a
/// plane. Entries are 64-bit keys, depth bits high and cell low: positive floats order like their
/// bit patterns, so one integer min keeps the nearest point together with its cell.
class OcclusionBuffer {
 public:
  /// `pixel_of_point[i]` (−1 = not visible), `depth[i]` (> 0 where visible) and
  /// `cell_of_point[i]` (−1 = outside the grid: still an occluder, never "the same cell").
  void build(int width, int height, int splat_px, const std::vector<int32_t>& pixel_of_point,
             const std::vector<float>& depth, const std::vector<int32_t>& cell_of_point);

  /// True if the nearest point at `pixel` belongs to another cell than `cell` (or to none); its
  /// depth goes to `*depth`. False where no point reaches or the cell itself is nearest: then
  /// nothing is known to stand in front of the cell there.
  bool occluder(uint32_t pixel, int cell, float* depth) const {
    if (pixel - first_ >= keys_.size()) return false;  // a row no splat reaches (unsigned wrap)
    const uint64_t key = keys_[pixel - first_];
    if (key == kEmpty || uint32_t(key) == uint32_t(cell)) return false;
    const uint32_t bits = uint32_t(key >> 32);
    std::memcpy(depth, &bits, sizeof *depth);
    return true;
  }

  /// Where build() splats: the stored rows from image row `row0` on, half-width r.
  struct Splat {
    uint64_t* keys;
    int width, height, row0, r;
  };

 private:
  void splatScalar(const Splat& s, const std::vector<int32_t>& pixel_of_point,
                   const std::vector<float>& depth, const std::vector<int32_t>& cell_of_point);
  void splatAvx2(const Splat& s, const std::vector<int32_t>& pixel_of_point,
                 const std::vector<float>& depth, const std::vector<int32_t>& cell_of_point);

  /// Above every key (a finite depth's bits are below 0x7f800000) and below 2^63, so signed and
  /// unsigned comparisons order keys alike.
  static constexpr uint64_t kEmpty = ~uint64_t(0) >> 1;
  std::vector<uint64_t> keys_;  // rows the splats reach, from pixel first_ on
  uint32_t first_ = 0;
};

}  // namespace terramrf
