#include "terramrf/adapters/opencv_image.hpp"

#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "terramrf/atomic_file.hpp"
#include "terramrf/errors.hpp"

namespace terramrf {

namespace {
/// libjpeg decodes a JPEG cut short (a copy interrupted, a full disk) without failing: it warns
/// "Premature end of JPEG file" on stderr, with no file name, and fills the missing rows with
/// grey, which colour and texture features would then read as data. A complete JPEG ends with
/// the end-of-image marker FF D9; in the entropy-coded data an FF byte is always followed by 00
/// or a restart marker, so FF D9 there means the end. Some writers pad after it, hence the
/// search over the last bytes rather than a look at the final two.
bool jpegIsCutShort(const std::vector<uchar>& bytes) {
  if (bytes.size() < 4 || bytes[0] != 0xFF || bytes[1] != 0xD8) return false;  // not a JPEG
  const std::size_t from = bytes.size() > 4096 ? bytes.size() - 4096 : 2;
  for (std::size_t i = bytes.size() - 1; i > from; --i)
    if (bytes[i - 1] == 0xFF && bytes[i] == 0xD9) return false;
  return true;
}

/// "16-bit unsigned" for CV_16U: OpenCV's depth codes alone mean nothing to whoever made the file.
std::string depthName(int depth) {
  switch (depth) {
    case CV_8S:
      return "8-bit signed";
    case CV_16U:
      return "16-bit unsigned";
    case CV_16S:
      return "16-bit signed";
    case CV_32S:
      return "32-bit signed";
    case CV_32F:
      return "32-bit float";
    case CV_64F:
      return "64-bit float";
    case CV_16F:
      return "16-bit float";
    default:
      return "non-8-bit";
  }
}
}  // namespace

Image readImage(const std::string& path) {
  if (!std::filesystem::exists(path)) throw InputError(path, "image file does not exist");
  if (!std::filesystem::is_regular_file(path)) throw InputError(path, "is not a file");
  std::ifstream in(path, std::ios::binary);
  std::vector<uchar> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (!in.good() && !in.eof()) throw InputError(path, "cannot be read");
  if (jpegIsCutShort(bytes))
    throw InputError(path,
                     "JPEG cut short: no end-of-image marker (FF D9) in its last 4 KiB; "
                     "the file is incomplete");
  if (bytes.empty()) throw InputError(path, "not a readable image (expected PNG/JPEG): empty file");
  cv::Mat m;
  try {
    m = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    throw InputError(path, "not a readable image (expected PNG/JPEG): " + e.msg);
  }
  if (m.empty()) throw InputError(path, "not a readable image (expected PNG/JPEG)");
  if (m.depth() != CV_8U) {
    throw InputError(path, "expected an 8-bit image, got " + depthName(m.depth()) +
                               " samples (OpenCV depth code " + std::to_string(m.depth()) + ")");
  }
  cv::Mat out;
  if (m.channels() == 1) out = m;
  else if (m.channels() == 3) cv::cvtColor(m, out, cv::COLOR_BGR2RGB);
  else if (m.channels() == 4) cv::cvtColor(m, out, cv::COLOR_BGRA2RGB);
  else
    throw InputError(path, "unsupported channel count " + std::to_string(m.channels()) +
                               "; expected 1 (grey), 3 (colour) or 4 (colour and alpha)");
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
