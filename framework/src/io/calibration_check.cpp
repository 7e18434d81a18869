#include "terramrf/io/calibration_check.hpp"

#include <cmath>
#include <cstdio>

#include "terramrf/errors.hpp"

namespace terramrf {
namespace {

std::string px(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.1f", v);
  return b;
}

std::string sizeText(int w, int h) { return std::to_string(w) + "x" + std::to_string(h) + " px"; }

std::string calibrationOf(const CameraModel& m) {
  return "the calibration" + (m.calibration.empty() ? std::string() : " (" + m.calibration + ")");
}

}  // namespace

std::optional<ImageSize> imageSizeParam(const std::vector<double>& value,
                                        const std::string& param) {
  if (value.empty()) return std::nullopt;
  if (value.size() != 2)
    throw ParamError(param, "has " + std::to_string(value.size()) +
                                " numbers; expected [width, height] in px (or [] for unchecked)");
  for (double v : value)
    if (!(v >= 1 && v <= 1e6 && v == std::round(v)))
      throw ParamError(param,
                       "expected two positive whole numbers [width, height] in px, got " + px(v));
  return ImageSize{int(value[0]), int(value[1])};
}

void checkCalibrationFitsImage(const CameraImage& cam, const std::optional<ImageSize>& expected) {
  if (!cam.image || cam.image->empty()) return;
  const int w = cam.image->width, h = cam.image->height;
  const CameraModel& m = cam.model;
  if (expected && ((*expected)[0] != w || (*expected)[1] != h))
    throw InputError(cam.source_path, "image is " + sizeText(w, h) + " but image_size says " +
                                          sizeText((*expected)[0], (*expected)[1]) + ", the size " +
                                          calibrationOf(m) + " was made for");
  // Image of the optical axis: for P = K [R | t] that is K's third column, (cx, cy).
  const Eigen::Vector3d axis = m.P.leftCols<3>() * m.P.block<1, 3>(2, 0).transpose();
  if (!(std::abs(axis.z()) > 1e-12))
    throw InputError(cam.source_path, calibrationOf(m) +
                                          " has a degenerate projection matrix (no principal "
                                          "point); expected P = K [R | t]");
  const double cx = axis.x() / axis.z(), cy = axis.y() / axis.z();
  // Without a size to compare, the principal point is all there is, and cropping or resizing the
  // image moves it off-centre (the readers take the model's size from the image, so nothing else
  // notices). The bounds are 2× the real calibrations' largest offsets and no more (numbers in
  // the header): 100 px cropped off a KITTI image moves cx 50 px, 4 % of the width, and 10 % (the
  // bound before) let that pass with every pixel lookup shifted by 100 px. With the size checked
  // exactly, only a gross misfit is looked for, so a camera whose principal point truly lies
  // off-centre can be read by giving image_size.
  const double band_u = expected ? kPrincipalPointBandWithSize : kPrincipalPointBandU;
  const double band_v = expected ? kPrincipalPointBandWithSize : kPrincipalPointBandV;
  if (!(std::abs(cx - 0.5 * w) <= band_u * w && std::abs(cy - 0.5 * h) <= band_v * h))
    throw InputError(
        cam.source_path,
        "image is " + sizeText(w, h) + " but the calibration's principal point (" + px(cx) + ", " +
            px(cy) + ") px is not near its centre (" + px(0.5 * w) + ", " + px(0.5 * h) + ") px " +
            (expected ? std::string("(expected in the middle half of the image); ")
                      : std::string("(expected within 2.5 % of its width and 8 % of its height "
                                    "of the centre; a camera whose principal point lies further "
                                    "off needs image_size); ")) +
            calibrationOf(m) +
            " was made for another image size (was the image resized or cropped?)");
}

}  // namespace terramrf
