#pragma once
// Structure-of-arrays point cloud: the hot loops (binning, moments, features) touch one or two
// attributes at a time, so separate contiguous arrays vectorise and stay in cache.
#include <cstddef>
#include <cstdint>
#include <vector>

namespace terramrf {

/// Ring index value for points whose laser ring is not known.
inline constexpr uint16_t kUnknownRing = 0xFFFF;

struct PointCloud {
  std::vector<float> x;          ///< [m], LiDAR frame: forward
  std::vector<float> y;          ///< [m], LiDAR frame: left
  std::vector<float> z;          ///< [m], LiDAR frame: up
  std::vector<float> intensity;  ///< sensor units; not normalised (RELLIS Ouster is ~0..0.012)
  std::vector<uint16_t> ring;    ///< laser ring (0 = top beam); kUnknownRing if unknown
  std::vector<float> time_s;     ///< time offset within the sweep [s]; empty if unknown

  std::size_t size() const { return x.size(); }
  bool empty() const { return x.empty(); }
  bool hasRing() const { return ring.size() == x.size() && !x.empty(); }
  bool hasTime() const { return time_s.size() == x.size() && !x.empty(); }

  void reserve(std::size_t n) {
    x.reserve(n);
    y.reserve(n);
    z.reserve(n);
    intensity.reserve(n);
    ring.reserve(n);
  }
  void clear() {
    x.clear();
    y.clear();
    z.clear();
    intensity.clear();
    ring.clear();
    time_s.clear();
  }
  void push_back(float px, float py, float pz, float pi, uint16_t pr = kUnknownRing) {
    x.push_back(px);
    y.push_back(py);
    z.push_back(pz);
    intensity.push_back(pi);
    ring.push_back(pr);
  }
};

}  // namespace terramrf
