#include "footprint_raster.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <utility>

namespace terramrf {

std::size_t FootprintRaster::spans(const std::vector<Eigen::Vector2d>& poly, int width, int height,
                                   Eigen::Vector2d* centroid) {
  spans_.clear();
  const std::size_t n = poly.size();
  if (n < 3 || width <= 0 || height <= 0) return 0;
  double ymin = poly[0].y(), ymax = ymin;
  for (const auto& p : poly) ymin = std::min(ymin, p.y()), ymax = std::max(ymax, p.y());
  // Rows whose centre v lies in [ymin, ymax), clipped to the image. Corners of cells just in front
  // of the camera can be ~1e9 px away, so clip in double before converting to int.
  const double v_lo = std::max(0.0, std::ceil(ymin));
  const double v_hi = std::min(double(height), std::ceil(ymax));
  std::size_t count = 0;
  double su = 0, sv = 0;
  // A row crosses at most n edges; a convex footprint (every cell seen from in front) exactly 0
  // or 2, which need no sort.
  xs_.resize(n);
  double* const xs = xs_.data();
  for (int v = int(v_lo); v < int(v_hi); ++v) {
    const double y = v;
    std::size_t crossings = 0;
    for (std::size_t i = 0, j = n - 1; i < n; j = i++) {
      const Eigen::Vector2d& a = poly[j];
      const Eigen::Vector2d& b = poly[i];
      if ((a.y() <= y) != (b.y() <= y))
        xs[crossings++] = a.x() + (y - a.y()) * (b.x() - a.x()) / (b.y() - a.y());
    }
    if (crossings == 2) {
      if (xs[1] < xs[0]) std::swap(xs[0], xs[1]);
    } else {
      std::sort(xs, xs + crossings);
    }
    for (std::size_t k = 0; k + 1 < crossings; k += 2) {
      // Pixel u is inside when xa <= u < xb.
      const double u0 = std::max(0.0, std::ceil(xs[k]));
      const double u1 = std::min(double(width), std::ceil(xs[k + 1]));
      if (u1 <= u0) continue;
      const int a = int(u0), b = int(u1);
      spans_.push_back({v, a, b});
      const std::size_t m = std::size_t(b - a);
      count += m;
      su += 0.5 * double(a + b - 1) * double(m);  // Σ u over u = a .. b-1
      sv += y * double(m);
    }
  }
  if (centroid && count > 0) *centroid = Eigen::Vector2d(su / double(count), sv / double(count));
  return count;
}

std::size_t FootprintRaster::rasterise(const std::vector<Eigen::Vector2d>& poly, int width,
                                       int height, std::size_t max_pixels,
                                       std::vector<uint32_t>& out, bool* shrunk) {
  if (shrunk) *shrunk = false;
  Eigen::Vector2d c(0, 0);
  std::size_t count = spans(poly, width, height, &c);
  if (count > max_pixels && max_pixels > 0) {
    if (shrunk) *shrunk = true;
    // Area scales with the square of the factor. Clipping makes the count fall slower than the
    // area for polygons much larger than the image, hence the loop; each pass is O(rows).
    scaled_ = poly;
    for (int pass = 0; pass < 32 && count > max_pixels; ++pass) {
      const double f = 0.98 * std::sqrt(double(max_pixels) / double(count));
      for (auto& p : scaled_) p = c + f * (p - c);
      count = spans(scaled_, width, height, nullptr);
    }
  }
  // Sized once and written span by span (a push_back per pixel cost a third of the fusion's
  // cell loop).
  const std::size_t written = max_pixels == 0 ? count : std::min(count, max_pixels);
  const std::size_t at = out.size();
  out.resize(at + written);
  uint32_t* o = out.data() + at;
  uint32_t* const end = o + written;
  for (const Span& s : spans_) {
    // The span's length clipped to what is left first: then the loop has one exit and vectorises.
    const uint32_t first = uint32_t(s.v) * uint32_t(width) + uint32_t(s.u0);
    const std::ptrdiff_t m = std::min<std::ptrdiff_t>(s.u1 - s.u0, end - o);
    for (std::ptrdiff_t k = 0; k < m; ++k) o[k] = first + uint32_t(k);
    o += m;
    if (o == end) break;
  }
  return written;
}

}  // namespace terramrf
