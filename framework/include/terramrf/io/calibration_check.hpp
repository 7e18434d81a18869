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

/// Checks `cam.model` (read from the files in `model.calibration`) against `cam.image` (read from
/// `cam.source_path`):
///  - `expected` given (a source's image_size): the image must be exactly that size;
///  - always: the principal point (the image of the optical axis; (cx, cy) of K for P = K [R | t])
///    must lie in the middle half of the image, |cx − w/2| ≤ w/4, |cy − h/2| ≤ h/4. Real cameras
///    have it near the centre (KITTI image_2 and RELLIS-3D within 4 % of the width and height,
///    the simulator at it), so the bound leaves a wide margin against false alarms; an image
///    shrunk below ~2/3 or grown beyond ~2× of the calibrated size fails it. Not caught: a milder
///    resize, or a crop that keeps the principal point central — give image_size for those.
/// Throws InputError(cam.source_path, ...) naming the image size, the principal point and the
/// calibration file(s). A camera without an image is left to its consumer.
void checkCalibrationFitsImage(const CameraImage& cam,
                               const std::optional<ImageSize>& expected = std::nullopt);

}  // namespace terramrf
