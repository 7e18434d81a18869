#pragma once
// A minimal owned 8-bit image so the core does not depend on OpenCV. Adapters convert to/from
// cv::Mat without copying where possible (the data pointer is contiguous, row-major, interleaved).
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace terramrf {

struct Image {
  int width = 0;     ///< [px]
  int height = 0;    ///< [px]
  int channels = 0;  ///< 1 (grey or label ids) or 3 (RGB order)
  std::vector<uint8_t> data;  ///< row-major, channels interleaved

  Image() = default;
  Image(int w, int h, int c) : width(w), height(h), channels(c), data(std::size_t(w) * h * c, 0) {}
  bool empty() const { return data.empty(); }
  uint8_t* at(int u, int v) { return &data[(std::size_t(v) * width + u) * channels]; }
  const uint8_t* at(int u, int v) const { return &data[(std::size_t(v) * width + u) * channels]; }
};

using ImagePtr = std::shared_ptr<const Image>;

}  // namespace terramrf
