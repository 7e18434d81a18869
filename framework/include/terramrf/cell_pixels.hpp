#pragma once
// Camera–LiDAR fusion result (paper 000 §4.5): for one camera of the frame, the pixel of each
// point and, per grid cell, the pixels the cell covers. Written by a fusion stage, read by image
// features (Haralick, homogeneity, colour). CSR layout like the grid's point lists.
#include <cstdint>
#include <vector>

namespace terramrf {

struct CellPixels {
  int camera = -1;                      ///< index into Frame::cameras
  int width = 0, height = 0;            ///< image size [px]
  std::vector<int32_t> pixel_of_point;  ///< v·width + u per point; -1 = not visible
  std::vector<uint32_t> offsets;        ///< cells + 1
  std::vector<uint32_t> pixels;         ///< v·width + u, grouped by cell

  uint32_t count(int cell) const { return offsets.empty() ? 0 : offsets[cell + 1] - offsets[cell]; }
  const uint32_t* begin(int cell) const { return pixels.data() + offsets[cell]; }
  const uint32_t* end(int cell) const { return pixels.data() + offsets[cell + 1]; }
};

}  // namespace terramrf
