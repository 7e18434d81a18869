#pragma once
// Scan conversion of a cell's projected footprint (a small polygon in pixel coordinates) into the
// pixels it covers, clipped to the image and bounded in count.
#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace terramrf {

/// Pixel convention (as CameraModel::project, KITTI and OpenCV): pixel (u, v) is centred on the
/// integer coordinates (u, v). It belongs to a polygon when its centre does; a centre on an edge
/// belongs to the polygon on its right / below (half-open), so two polygons sharing an edge never
/// both claim a pixel.
class FootprintRaster {
 public:
  /// Appends v·width + u of every covered pixel to `out`, row by row, left to right (sorted).
  /// `poly` is any simple polygon (even–odd rule), here the 4 projected corners of a cell.
  /// If more than `max_pixels` would be covered, the polygon is shrunk about the centre of its
  /// visible part until it covers at most `max_pixels`: the kept pixels stay contiguous at the
  /// native resolution, which the co-occurrence and neighbourhood features need.
  /// Returns the number of pixels appended; `*shrunk` tells whether the cap applied.
  std::size_t rasterise(const std::vector<Eigen::Vector2d>& poly, int width, int height,
                        std::size_t max_pixels, std::vector<uint32_t>& out, bool* shrunk = nullptr);

 private:
  struct Span {
    int v, u0, u1;  // pixels u0 .. u1-1 of row v
  };
  /// Spans of the polygon clipped to the image; returns the pixel count and the centroid of the
  /// covered pixel centres.
  std::size_t spans(const std::vector<Eigen::Vector2d>& poly, int width, int height,
                    Eigen::Vector2d* centroid);

  std::vector<Span> spans_;
  std::vector<double> xs_;
  std::vector<Eigen::Vector2d> scaled_;
};

}  // namespace terramrf
