#pragma once
// The camera names an output has met in a run, for outputs that write one image per camera.
#include <algorithm>
#include <string>
#include <vector>

#include "terramrf/frame.hpp"

namespace terramrf {

/// The source's camera names (RunInfo::cameras) and those of the frames written so far. They
/// name a failed frame's camera images in Output::frameFiles when the frame could not be read, so
/// an earlier run's images of it are removed all the same.
class KnownCameras {
 public:
  void note(const std::string& name) {
    if (std::find(names_.begin(), names_.end(), name) == names_.end()) names_.push_back(name);
  }
  void note(const std::vector<std::string>& names) {
    for (const std::string& n : names) note(n);
  }
  /// Those noted, then the cameras of `frame` (cameraName) when it was read (not null).
  std::vector<std::string> with(const Frame* frame) const {
    std::vector<std::string> out = names_;
    if (frame)
      for (std::size_t i = 0; i < frame->cameras.size(); ++i) out.push_back(cameraName(*frame, i));
    return out;
  }

 private:
  std::vector<std::string> names_;
};

}  // namespace terramrf
