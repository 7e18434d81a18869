#pragma once
// A camera's calibration (CameraModel) ⇄ terramrf_msgs::camera_info_t. LCM-free header.
#include <cstddef>
#include <string>

#include "terramrf/camera.hpp"
#include "terramrf/lcm/message_header.hpp"

namespace terramrf {

/// The model's name travels as `camera`; header.coordinate_frame is not carried.
MessageBytes encodeCameraInfo(const CameraModel& model, const MessageHeader& header);

struct DecodedCameraInfo {
  MessageHeader header;
  CameraModel model;  ///< name = the message's camera
};
/// Throws InputError (file = `source`) on foreign or truncated bytes, a size that is not
/// positive, non-finite numbers, or a T_camera_lidar whose rotation part is no rotation. Every
/// number round-trips to the bit.
DecodedCameraInfo decodeCameraInfo(const void* data, std::size_t size,
                                   const std::string& source = "camera_info_t");

}  // namespace terramrf
