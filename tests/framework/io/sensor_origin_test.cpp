#include "terramrf/io/sensor_origin.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "io_test_util.hpp"

namespace terramrf {
namespace {

using test::readDataScan;
using test::seq00Scan;

TEST(SensorOrigin, FindsTheShiftedOpen3dMlScan) {
  const std::string base = "semantickitti_o3dml_demo/converted_semantickitti/velodyne/";
  const SensorOriginEstimate a = estimateSensorOrigin(readDataScan(base + "000700.bin"));
  ASSERT_TRUE(a.ok) << a.note;
  std::printf("000700 origin (%.2f, %.2f), ring radius %.2f m, %d points\n", a.origin_m.x(),
              a.origin_m.y(), a.ring_radius_m, a.inliers);
  // PROVENANCE.md: origin near (0.0, -100.1).
  EXPECT_LT((a.origin_m - Eigen::Vector2d(0.0, -100.1)).norm(), 0.5);
  const SensorOriginEstimate b = estimateSensorOrigin(readDataScan(base + "000750.bin"));
  ASSERT_TRUE(b.ok) << b.note;
  std::printf("000750 origin (%.2f, %.2f)\n", b.origin_m.x(), b.origin_m.y());
  EXPECT_LT(b.origin_m.norm(), 0.5);
  for (int i = 0; i < 6; ++i) {
    const SensorOriginEstimate k = estimateSensorOrigin(readDataScan(seq00Scan(i)));
    ASSERT_TRUE(k.ok);
    EXPECT_LT(k.origin_m.norm(), 0.5) << "seq 00 frame " << i;
  }
  for (int i = 0; i < 2; ++i) {
    const SensorOriginEstimate k = estimateSensorOrigin(
        readDataScan("kitti_object_fusion/training/velodyne/00000" + std::to_string(i) + ".bin"));
    ASSERT_TRUE(k.ok);
    EXPECT_LT(k.origin_m.norm(), 0.5) << "object frame " << i;
  }
  PointCloud few;
  few.push_back(1, 1, 1, 0);
  EXPECT_FALSE(estimateSensorOrigin(few).ok);
}

}  // namespace
}  // namespace terramrf
