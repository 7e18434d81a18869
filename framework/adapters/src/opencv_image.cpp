#include "terramrf/adapters/opencv_image.hpp"

#include <cstring>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "terramrf/atomic_file.hpp"
#include "terramrf/errors.hpp"

namespace terramrf {

Image readImage(const std::string& path) {
  if (!std::filesystem::exists(path)) throw InputError(path, "image file does not exist");
  cv::Mat m = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (m.empty()) throw InputError(path, "not a readable image (expected PNG/JPEG)");
  if (m.depth() != CV_8U) {
    throw InputError(path, "expected an 8-bit image, got depth code " + std::to_string(m.depth()));
  }
  cv::Mat out;
  if (m.channels() == 1) out = m;
  else if (m.channels() == 3) cv::cvtColor(m, out, cv::COLOR_BGR2RGB);
  else if (m.channels() == 4) cv::cvtColor(m, out, cv::COLOR_BGRA2RGB);
  else throw InputError(path, "unsupported channel count " + std::to_string(m.channels()));
  Image img(out.cols, out.rows, out.channels());
  for (int r = 0; r < out.rows; ++r)
    std::memcpy(img.data.data() + std::size_t(r) * out.cols * out.channels(), out.ptr(r),
                std::size_t(out.cols) * out.channels());
  return img;
}

void writeImageAtomic(const std::string& path, const Image& image) {
  if (image.empty() || (image.channels != 1 && image.channels != 3))
    throw std::runtime_error("cannot write image '" + path + "': empty or not 1/3 channels");
  cv::Mat m(image.height, image.width, image.channels == 1 ? CV_8UC1 : CV_8UC3,
            const_cast<uint8_t*>(image.data.data()));
  cv::Mat bgr;
  if (image.channels == 3) cv::cvtColor(m, bgr, cv::COLOR_RGB2BGR);
  else bgr = m;
  std::string ext = std::filesystem::path(path).extension().string();
  if (ext.empty()) ext = ".png";
  std::vector<uint8_t> buf;
  if (!cv::imencode(ext, bgr, buf))
    throw std::runtime_error("cannot encode image '" + path + "' as " + ext);
  writeFileAtomic(path, std::string_view(reinterpret_cast<const char*>(buf.data()), buf.size()));
}

}  // namespace terramrf
