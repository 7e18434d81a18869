// checkCalibrationFitsImage / imageSizeParam on the real calibrations (KITTI object, KITTI
// odometry, RELLIS-3D, the simulator's centred camera) at their own image sizes and resized.
#include "terramrf/io/calibration_check.hpp"

#include <gtest/gtest.h>

#include <memory>

#include "terramrf/errors.hpp"
#include "terramrf/io/kitti.hpp"
#include "terramrf/io/rellis.hpp"
#include "test_support.hpp"

namespace terramrf {
namespace {

CameraImage withImage(const CameraModel& m, int w, int h, const std::string& path) {
  CameraImage c;
  c.model = m;
  c.image = std::make_shared<Image>(w, h, 3);
  c.source_path = path;
  return c;
}

/// The InputError message of the check, "" if it passes; the error must name the image.
std::string failure(const CameraImage& c, const std::optional<ImageSize>& expected = {}) {
  try {
    checkCalibrationFitsImage(c, expected);
    return "";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), c.source_path);
    return e.what();
  }
}

TEST(CalibrationCheck, RealCalibrationsFitTheirImages) {
  const std::string kitti = test::dataPath("kitti_object_fusion/training/calib/");
  const KittiCalib c0 = readKittiCalib(kitti + "000000.txt"),
                   c1 = readKittiCalib(kitti + "000001.txt");
  EXPECT_EQ(failure(withImage(kittiCamera(c0, 2, 1224, 370), 1224, 370, "0.png")), "");
  EXPECT_EQ(failure(withImage(kittiCamera(c1, 2, 1242, 375), 1242, 375, "1.png")), "");
  // KITTI odometry sequence 00 (1241 × 376).
  const KittiCalib odo =
      readKittiCalib(test::dataPath("semantickitti_seq00_000000-000005/sequences/00/calib.txt"));
  EXPECT_EQ(failure(withImage(kittiCamera(odo, 2, 1241, 376), 1241, 376, "o.png")), "");
  const std::string rellis = test::dataPath("rellis3d_example_000104/");
  const CameraModel r =
      rellisCamera(rellis + "camera_info.txt", rellis + "transforms.yaml", 1920, 1200);
  EXPECT_EQ(failure(withImage(r, 1920, 1200, "r.jpg")), "");
  // The simulator puts the principal point at the centre (sim/camera.cpp).
  CameraModel sim;
  sim.P << 300, 0, 160, 0, 0, 300, 120, 0, 0, 0, 1, 0;
  EXPECT_EQ(failure(withImage(sim, 320, 240, "sim")), "");
  // Exact size asked for and met.
  EXPECT_EQ(failure(withImage(r, 1920, 1200, "r.jpg"), ImageSize{1920, 1200}), "");
}

TEST(CalibrationCheck, ResizedImagesAreErrorsNamingImageAndCalibration) {
  const std::string calib = test::dataPath("kitti_object_fusion/training/calib/000001.txt");
  const CameraModel k = kittiCamera(readKittiCalib(calib), 2, 621, 188);
  // Halved (the audit's case: 2180 instead of 20259 points in the image, no error) and doubled.
  for (const auto& [w, h] : {std::pair{621, 188}, std::pair{2484, 750}}) {
    const std::string what = failure(withImage(k, w, h, "/d/image_2/000001.png"));
    EXPECT_NE(what.find("/d/image_2/000001.png"), std::string::npos) << what;
    EXPECT_NE(what.find(calib + " (P2, R0_rect, Tr_velo_to_cam)"), std::string::npos) << what;
    EXPECT_NE(what.find(std::to_string(w) + "x" + std::to_string(h) + " px"), std::string::npos);
    EXPECT_NE(what.find("principal point (609.6, 172.9) px"), std::string::npos) << what;
  }
  const std::string rellis = test::dataPath("rellis3d_example_000104/");
  const CameraModel r =
      rellisCamera(rellis + "camera_info.txt", rellis + "transforms.yaml", 960, 600);
  const std::string what = failure(withImage(r, 960, 600, "/d/frame.jpg"));
  EXPECT_NE(what.find(rellis + "camera_info.txt"), std::string::npos) << what;
  EXPECT_NE(what.find(rellis + "transforms.yaml"), std::string::npos) << what;
  // A 3 % smaller image keeps the principal point central: only image_size catches it.
  const CameraModel k1 = kittiCamera(readKittiCalib(calib), 2, 1205, 364);
  EXPECT_EQ(failure(withImage(k1, 1205, 364, "s.png")), "");
  const std::string exact = failure(withImage(k1, 1205, 364, "s.png"), ImageSize{1242, 375});
  EXPECT_NE(exact.find("1205x364 px"), std::string::npos) << exact;
  EXPECT_NE(exact.find("1242x375 px"), std::string::npos) << exact;
  EXPECT_NE(exact.find(calib), std::string::npos) << exact;
}

// Without image_size the principal point must lie within 2.5 % of the width and 8 % of the height
// of the image's centre (2× the real calibrations' largest offsets: cx 1.07 %, cy 3.9 %), so 0.75×
// and 1.3× resizes are caught; the middle half of the image (the rule two revisions back) let
// 0.67–2× pass.
TEST(CalibrationCheck, ResizesOfAQuarterAreCaughtWithoutImageSize) {
  const std::string calib = test::dataPath("kitti_object_fusion/training/calib/000001.txt");
  const KittiCalib c1 = readKittiCalib(calib);
  const std::string rellis = test::dataPath("rellis3d_example_000104/");
  const CameraModel r =
      rellisCamera(rellis + "camera_info.txt", rellis + "transforms.yaml", 1920, 1200);
  struct Case {
    CameraModel model;
    int w, h;
  };
  for (const Case& c : {Case{kittiCamera(c1, 2, 932, 281), 932, 281},    // KITTI 0.75×
                        Case{kittiCamera(c1, 2, 1615, 488), 1615, 488},  // KITTI 1.3×
                        Case{r, 1440, 900},                              // RELLIS 0.75×
                        Case{r, 2496, 1560}}) {                          // RELLIS 1.3×
    const std::string what = failure(withImage(c.model, c.w, c.h, "/d/img.png"));
    EXPECT_NE(what.find(std::to_string(c.w) + "x" + std::to_string(c.h) + " px"), std::string::npos)
        << what;
    EXPECT_NE(what.find("expected within 2.5 % of its width and 8 % of its height of the centre"),
              std::string::npos)
        << what;
  }
  // A camera whose principal point really is off-centre (a cropped sensor: cx at 35 % of the
  // width) fails the 2.5 % rule at its own size; giving its image_size checks the size exactly
  // instead, and then only the middle-half rule remains.
  CameraModel crop;
  crop.P << 500, 0, 224, 0, 0, 500, 240, 0, 0, 0, 1, 0;
  crop.calibration = "/d/crop_calib.txt";
  EXPECT_NE(failure(withImage(crop, 640, 480, "c.png")).find("principal point (224.0, 240.0) px"),
            std::string::npos);
  EXPECT_EQ(failure(withImage(crop, 640, 480, "c.png"), ImageSize{640, 480}), "");
  const std::string halved = failure(withImage(crop, 320, 240, "c.png"), ImageSize{320, 240});
  EXPECT_NE(halved.find("expected in the middle half of the image"), std::string::npos) << halved;
}

// The readers take the model's size from the image, so a cropped image kept its calibration and
// every pixel lookup was shifted by the crop: with 100 px cut off (KITTI 1242 → 1142, 8 % of the
// width) cx lies 38.6 px, 3.4 %, right of the new centre, which the 10 % bound before let pass.
// The same whether the left or the right edge was cut: the calibration does not change.
TEST(CalibrationCheck, ACroppedImageIsAnErrorNamingImageCalibrationAndWhatWasExpected) {
  const std::string dir = test::dataPath("kitti_object_fusion/training/calib/");
  const std::string rellis = test::dataPath("rellis3d_example_000104/");
  struct Case {
    std::string calib;  // a file the message must name
    CameraModel model;  // as a reader builds it for the cropped image
    int w, h;
  };
  const std::vector<Case> cases = {
      {dir + "000001.txt", kittiCamera(readKittiCalib(dir + "000001.txt"), 2, 1142, 375), 1142,
       375},
      {dir + "000000.txt", kittiCamera(readKittiCalib(dir + "000000.txt"), 2, 1124, 370), 1124,
       370},
      // RELLIS-3D 8 % (154 px) narrower; and 100 px (5 %) too.
      {rellis + "camera_info.txt",
       rellisCamera(rellis + "camera_info.txt", rellis + "transforms.yaml", 1766, 1200), 1766,
       1200},
      {rellis + "camera_info.txt",
       rellisCamera(rellis + "camera_info.txt", rellis + "transforms.yaml", 1820, 1200), 1820,
       1200},
      // 100 px off the bottom of KITTI 000001 (27 %): cy 172.9, 14.6 px above the centre of 375,
      // is 35.4 px (12.9 %) below that of 275.
      {dir + "000001.txt", kittiCamera(readKittiCalib(dir + "000001.txt"), 2, 1242, 275), 1242,
       275}};
  for (const Case& c : cases) {
    const std::string what = failure(withImage(c.model, c.w, c.h, "/d/image_2/cropped.png"));
    EXPECT_NE(what.find("/d/image_2/cropped.png"), std::string::npos) << what;
    EXPECT_NE(what.find(c.calib), std::string::npos) << what;
    EXPECT_NE(what.find(std::to_string(c.w) + "x" + std::to_string(c.h) + " px"), std::string::npos)
        << what;
    EXPECT_NE(what.find("expected within 2.5 % of its width and 8 % of its height of the centre"),
              std::string::npos)
        << what;
    EXPECT_NE(what.find("resized or cropped"), std::string::npos) << what;
  }
  // The smallest crops caught, per calibration: 81 px of KITTI 000001's width, 74 of 000000's
  // and of RELLIS-3D's; one pixel less still passes.
  const KittiCalib c1 = readKittiCalib(dir + "000001.txt"), c0 = readKittiCalib(dir + "000000.txt");
  EXPECT_NE(failure(withImage(kittiCamera(c1, 2, 1161, 375), 1161, 375, "a.png")), "");
  EXPECT_EQ(failure(withImage(kittiCamera(c1, 2, 1162, 375), 1162, 375, "a.png")), "");
  EXPECT_NE(failure(withImage(kittiCamera(c0, 2, 1150, 370), 1150, 370, "b.png")), "");
  EXPECT_EQ(failure(withImage(kittiCamera(c0, 2, 1151, 370), 1151, 370, "b.png")), "");
  const CameraModel r =
      rellisCamera(rellis + "camera_info.txt", rellis + "transforms.yaml", 1920, 1200);
  EXPECT_NE(failure(withImage(r, 1846, 1200, "r.jpg")), "");
  EXPECT_EQ(failure(withImage(r, 1847, 1200, "r.jpg")), "");
}

TEST(CalibrationCheck, DegenerateProjectionAndNoImage) {
  CameraModel zero;
  zero.calibration = "/d/calib.txt (P2, Tr)";
  const std::string what = failure(withImage(zero, 100, 100, "x.png"));
  EXPECT_NE(what.find("degenerate"), std::string::npos) << what;
  EXPECT_NE(what.find("/d/calib.txt (P2, Tr)"), std::string::npos) << what;
  CameraImage none;  // no image: left to the consumer (camera_fusion names it)
  none.model = zero;
  EXPECT_NO_THROW(checkCalibrationFitsImage(none));
}

TEST(CalibrationCheck, ImageSizeParameter) {
  EXPECT_FALSE(imageSizeParam({}).has_value());
  EXPECT_EQ(*imageSizeParam({1242, 375}), (ImageSize{1242, 375}));
  for (const std::vector<double>& bad :
       {std::vector<double>{1242}, {1242, 375, 3}, {0, 375}, {1242.5, 375}, {-1, 2}}) {
    try {
      imageSizeParam(bad);
      ADD_FAILURE() << "accepted " << bad.size() << " numbers";
    } catch (const ParamError& e) {
      EXPECT_EQ(e.param(), "image_size");
    }
  }
}

}  // namespace
}  // namespace terramrf
