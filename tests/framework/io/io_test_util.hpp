#pragma once
// Small helpers shared by the io reader tests.
#include <cstdint>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "terramrf/frame.hpp"
#include "terramrf/io/kitti.hpp"
#include "test_support.hpp"

namespace terramrf::test {

inline void writeBytes(const std::string& path, const void* data, std::size_t bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(static_cast<const char*>(data), std::streamsize(bytes));
}

inline void writeScan(const std::string& path, const std::vector<float>& xyzi) {
  writeBytes(path, xyzi.data(), xyzi.size() * sizeof(float));
}

inline void writeLabels(const std::string& path, const std::vector<uint32_t>& labels) {
  writeBytes(path, labels.data(), labels.size() * sizeof(uint32_t));
}

inline std::map<uint32_t, std::size_t> histogram(const std::vector<uint32_t>& v) {
  std::map<uint32_t, std::size_t> h;
  for (uint32_t x : v) ++h[x];
  return h;
}

inline std::map<int, std::size_t> histogram(const std::vector<uint8_t>& v) {
  std::map<int, std::size_t> h;
  for (uint8_t x : v) ++h[x];
  return h;
}

/// A KITTI .bin of the shared data folder (path relative to it), read as the reader reads it.
inline PointCloud readDataScan(const std::string& rel) {
  PointCloud c;
  readKittiScan(dataPath(rel), c);
  return c;
}

/// SemanticKITTI sequence 00 frame i (0–5) of the shared data folder, relative to it.
inline std::string seq00Scan(int i) {
  return "semantickitti_seq00_000000-000005/sequences/00/velodyne/00000" + std::to_string(i) +
         ".bin";
}

}  // namespace terramrf::test
