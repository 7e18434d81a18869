#pragma once
// Does a camera calibration read from files fit the image it is paired with? KITTI's calib.txt
// and RELLIS-3D's camera_info.txt store no image size, so a source takes the size from the image
// and a resized image would otherwise be accepted with a calibration that no longer fits it (KITTI
// object 000000 halved: 2180 instead of 20259 points in the image, no error). Shared by the
// readers that pair an image file with calibration files (semantickitti, rellis3d).
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "terramrf/camera.hpp"

namespace terramrf {

using ImageSize = std::array<int, 2>;  ///< width, height [px]

/// Value of a source's `image_size` parameter ([width, height] px): nullopt when empty (the size is
/// not checked). Throws ParamError(param, ...) unless empty or two positive whole numbers.
std::optional<ImageSize> imageSizeParam(const std::vector<double>& value,
                                        const std::string& param = "image_size");

/// How far from the image centre checkCalibrationFitsImage lets the principal point lie, as a
/// fraction of the width (cx) and height (cy): without image_size, and with it (then the size
/// itself is compared exactly).
constexpr double kPrincipalPointBand = 0.10;
constexpr double kPrincipalPointBandWithSize = 0.25;

/// Checks `cam.model` (read from the files in `model.calibration`) against `cam.image` (read from
/// `cam.source_path`):
///  - `expected` given (a source's image_size): the image must be exactly that size, and the
///    principal point (the image of the optical axis; (cx, cy) of K for P = K [R | t]) must lie
///    in the middle half of the image, |cx − w/2| ≤ w/4, |cy − h/2| ≤ h/4;
///  - without it: the principal point must lie within 10 % of the width and height of the
///    centre, |cx − w/2| ≤ 0.1 w, |cy − h/2| ≤ 0.1 h. Real cameras have it near the centre (KITTI
///    image_2 and RELLIS-3D within 4 %, at most 3.9 %: KITTI object 000001's cy; the simulator at
///    it), so the bound leaves 2.5× that against false alarms; an image shrunk below ~0.82× or
///    grown beyond ~1.26× of the calibrated size fails it (0.75× and 1.3× on every real
///    calibration). Not caught: a milder resize, or a crop that keeps the principal point
///    central — give image_size for those, and for a camera whose principal point truly lies
///    further off-centre.
/// Throws InputError(cam.source_path, ...) naming the image size, the principal point and the
/// calibration file(s). A camera without an image is left to its consumer.
void checkCalibrationFitsImage(const CameraImage& cam,
                               const std::optional<ImageSize>& expected = std::nullopt);

}  // namespace terramrf
