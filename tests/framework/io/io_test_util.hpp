#pragma once
// Small helpers shared by the io reader tests.
#include <cstdint>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "terramrf/frame.hpp"

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

}  // namespace terramrf::test
