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
/// fraction of the width (cx) and of the height (cy): without image_size (then this is the only
/// check of the size), and with it (then the size itself is compared exactly).
constexpr double kPrincipalPointBandU = 0.025;
constexpr double kPrincipalPointBandV = 0.08;
constexpr double kPrincipalPointBandWithSize = 0.25;

/// Checks `cam.model` (read from the files in `model.calibration`) against `cam.image` (read from
/// `cam.source_path`):
///  - `expected` given (a source's image_size): the image must be exactly that size, and the
///    principal point (the image of the optical axis; (cx, cy) of K for P = K [R | t]) must lie
///    in the middle half of the image, |cx − w/2| ≤ w/4, |cy − h/2| ≤ h/4;
///  - without it: the principal point must lie within 2.5 % of the width and 8 % of the height
///    of the centre, |cx − w/2| ≤ 0.025 w, |cy − h/2| ≤ 0.08 h. Each bound is at least 2× the
///    largest offset of a real calibration (cx: 1.07 %, KITTI odometry seq 00; cy: 3.9 %, KITTI
///    object 000001; RELLIS-3D 0.48 % and 2.0 %; the simulator's is at the centre). Cropping moves
///    the principal point off-centre by half the crop, so 100 px off either side of a KITTI image
///    (8 % of its width) fails, as does a resize below ~0.93× or above ~1.07× on every real
///    calibration. Not caught: milder crops and resizes, and a crop that keeps the principal
///    point central — give image_size for those, and for a camera whose principal point truly
///    lies further off-centre.
/// Throws InputError(cam.source_path, ...) naming the image size, the principal point and the
/// calibration file(s). A camera without an image is left to its consumer.
void checkCalibrationFitsImage(const CameraImage& cam,
                               const std::optional<ImageSize>& expected = std::nullopt);

}  // namespace terramrf
