// fusion::fusedCameras (include/terramrf/camera_fusion/fused_cameras.hpp), what every image feature
// calls first: which camera index is wrong, and which is right but was not fused.
#include "terramrf/camera_fusion/fused_cameras.hpp"

#include <gtest/gtest.h>

#include "plugins/feature/camera_fusion/fusion_test_frame.hpp"

namespace terramrf {
namespace {

using test::forwardCamera;
using test::groundFrame;
using test::noFill;
using test::StageRunner;

/// The InputError message of fusedCameras(camera), "" if it returns; the error names the frame.
std::string failure(StageRunner& r, const Frame& f, int camera) {
  try {
    fusion::fusedCameras(r.ctx, camera, "haralick");
    return "";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), f.source_path);
    return e.what();
  }
}

// `camera: 1` on a frame with one camera said "no fused pixels for camera 1 … run a
// camera_fusion stage before it", which no camera_fusion stage could cure.
TEST(FusedCameras, ACameraIndexBeyondTheFramesCamerasIsNamedAsSuch) {
  Frame f = groundFrame(forwardCamera("image_2"), noFill);
  StageRunner r;
  r.add("camera_fusion");
  r.run(f);
  EXPECT_EQ(failure(r, f, 0), "");
  const std::string what = failure(r, f, 1);
  EXPECT_NE(what.find("camera 1 is beyond frame 000007's cameras; it has 1 (0 'image_2')"),
            std::string::npos)
      << what;
  EXPECT_NE(what.find("expected camera: an index among them, or −1 for all"), std::string::npos)
      << what;
  EXPECT_EQ(what.find("run a camera_fusion stage"), std::string::npos) << what;
  // Two cameras listed; 2 is beyond them.
  Frame g = groundFrame(forwardCamera("second"), noFill, 3, "/data/second/000007.png");
  f.cameras.push_back(g.cameras[0]);
  r.run(f);
  const std::string two = failure(r, f, 2);
  EXPECT_NE(two.find("it has 2 (0 'image_2', 1 'second')"), std::string::npos) << two;
}

TEST(FusedCameras, AnExistingCameraThatWasNotFusedKeepsTheFusionHint) {
  Frame f = groundFrame(forwardCamera("image_2"), noFill);
  Frame g = groundFrame(forwardCamera("second"), noFill, 3, "/data/second/000007.png");
  f.cameras.push_back(g.cameras[0]);
  StageRunner r;
  r.add("camera_fusion", "{cameras: [image_2]}");
  r.run(f);
  EXPECT_EQ(failure(r, f, 0), "");
  const std::string what = failure(r, f, 1);
  EXPECT_NE(what.find("haralick: no fused pixels for camera 1 in frame 000007; run a camera_fusion "
                      "stage before it"),
            std::string::npos)
      << what;
  // No fusion at all: every camera, also −1, gets the hint.
  StageRunner none;
  none.prepare(f);
  EXPECT_NE(failure(none, f, -1).find("no fused pixels for any camera"), std::string::npos);
}

}  // namespace
}  // namespace terramrf
