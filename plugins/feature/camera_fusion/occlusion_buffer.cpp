#include "occlusion_buffer.hpp"

#include <algorithm>
#include <limits>

namespace terramrf {

void OcclusionBuffer::build(int width, int height, int splat_px,
                            const std::vector<int32_t>& pixel_of_point,
                            const std::vector<float>& depth,
                            const std::vector<int32_t>& cell_of_point) {
  const int r = std::max(0, splat_px);
  const std::size_t n = pixel_of_point.size();
  // Only the rows the splats reach are stored (a scan fills the lower two thirds of a KITTI
  // image): the buffer is cleared every frame, and that clearing was a quarter of its cost.
  int32_t lo = std::numeric_limits<int32_t>::max(), hi = -1;
  for (std::size_t i = 0; i < n; ++i) {
    const int32_t px = pixel_of_point[i];
    if (px < 0) continue;
    lo = std::min(lo, px);
    hi = std::max(hi, px);
  }
  if (hi < 0) {
    first_ = 0;
    keys_.clear();
    return;
  }
  const int row0 = std::max(0, lo / width - r), row1 = std::min(height - 1, hi / width + r);
  first_ = uint32_t(row0) * uint32_t(width);
  keys_.assign(std::size_t(row1 - row0 + 1) * std::size_t(width), kEmpty);
  uint64_t* const base = keys_.data() - first_;  // indexed by the image's own pixel numbers
  for (std::size_t i = 0; i < n; ++i) {
    const int32_t px = pixel_of_point[i];
    if (px < 0) continue;
    uint32_t bits;
    std::memcpy(&bits, &depth[i], sizeof bits);
    const uint64_t key = (uint64_t(bits) << 32) | uint32_t(cell_of_point[i]);
    const int u = px % width, v = px / width;
    const int u0 = std::max(0, u - r), u1 = std::min(width - 1, u + r);
    const int v0 = std::max(0, v - r), v1 = std::min(height - 1, v + r);
    for (int y = v0; y <= v1; ++y) {
      uint64_t* row = base + std::size_t(y) * width;
      for (int x = u0; x <= u1; ++x) row[x] = std::min(row[x], key);
    }
  }
}

}  // namespace terramrf
