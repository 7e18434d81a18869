#pragma once
// OpenCV adapter: image files <-> terramrf::Image. The core never includes OpenCV.
#include <string>

#include "terramrf/image.hpp"

namespace terramrf {

/// Reads PNG/JPG/...; colour images come back as 3-channel RGB, single-channel as 1 channel
/// (values unchanged, e.g. label ids). Throws InputError naming the file.
Image readImage(const std::string& path);

/// Encodes by extension (.png, .jpg) and writes atomically. Throws naming the path.
void writeImageAtomic(const std::string& path, const Image& image);

}  // namespace terramrf
