// Simulator frames written as a KITTI sequence (KittiSequenceWriter) and read back by the
// "semantickitti" source: points, labels, poses and camera must survive, and the rings recovered
// from the .bin alone must match the simulator's true rings (rings/NNNNNN.bin).
#include <gtest/gtest.h>

#include <filesystem>

#include "terramrf/io/kitti_writer.hpp"
#include "terramrf/param_values.hpp"
#include "terramrf/registry.hpp"
#include "test_support.hpp"

namespace terramrf {
namespace {

std::unique_ptr<Source> makeSource(PluginRegistry& reg, const std::string& type,
                                   const std::string& params, const PluginContext& ctx) {
  auto p = reg.create(type);
  setParams(*p, params, ctx);
  return std::unique_ptr<Source>(dynamic_cast<Source*>(p.release()));
}

// A front and a rear camera written as image_2 / image_3 (the rear one's rotation folded into
// P3) read back with the same projections, images and pixel truth.
TEST(SemanticKittiSimulatorRoundTrip, FrontAndRearCameras) {
  PluginRegistry reg({test::pluginDir()});
  LabelSet labels = LabelSet::defaults();
  PluginContext ctx;
  ctx.labels = &labels;
  test::TempDir dir;
  auto sim = makeSource(reg, "simulator",
                        "{frames: 1, seed: 5, camera_yaws_deg: [0, 180], camera_width: 160, "
                        "camera_height: 64, camera_fx: 90}",
                        ctx);
  const Frame t = sim->read(0);
  ASSERT_EQ(t.cameras.size(), 2u);
  {
    KittiSequenceWriter w(dir.str());
    w.write(t);
    w.finish();
  }
  ASSERT_TRUE(std::filesystem::exists(dir.str() + "/image_3/000000.png"));
  ASSERT_TRUE(std::filesystem::exists(dir.str() + "/image_3_truth/000000.png"));
  auto back = makeSource(
      reg, "semantickitti",
      "{path: " + dir.str() + ", use_labels: false, use_images: true, cameras: [image_2, image_3]}",
      ctx);
  const Frame f = back->read(0);
  ASSERT_EQ(f.cameras.size(), 2u);
  std::size_t seen[2] = {0, 0};
  for (int c = 0; c < 2; ++c) {
    EXPECT_EQ(f.cameras[c].image->data, t.cameras[c].image->data);
    const CameraModel &a = f.cameras[c].model, &b = t.cameras[c].model;
    EXPECT_TRUE(a.T_camera_lidar.isApprox(b.T_camera_lidar, 1e-6)) << c;
    for (std::size_t i = 0; i < t.points.size(); i += 13) {
      const Eigen::Vector3d x(t.points.x[i], t.points.y[i], t.points.z[i]);
      const auto pa = a.project(x), pb = b.project(x);
      ASSERT_EQ(pa.has_value(), pb.has_value()) << c << " " << x.transpose();
      if (!pa) continue;
      ++seen[c];
      EXPECT_LT((*pa - *pb).norm(), 1e-3);
    }
  }
  EXPECT_GT(seen[0], 200u);
  EXPECT_GT(seen[1], 200u);
}

TEST(SemanticKittiSimulatorRoundTrip, RingsPosesLabelsAndCamera) {
  PluginRegistry reg({test::pluginDir()});
  LabelSet labels = LabelSet::defaults();
  PluginContext ctx;
  ctx.labels = &labels;
  const std::string sim_map = test::sourceDir() + "/configs/label_maps/simulator.yaml";
  ASSERT_TRUE(std::filesystem::exists(sim_map));
  for (const std::string order : {"ring", "column"}) {
    test::TempDir dir;
    auto sim = makeSource(reg, "simulator",
                          "{frames: 2, seed: 11, point_order: " + order +
                              ", camera_width: 160, camera_height: 64, camera_fx: 90}",
                          ctx);
    std::vector<Frame> truth;
    {
      KittiSequenceWriter w(dir.str());
      for (std::size_t i = 0; i < sim->size(); ++i) {
        truth.push_back(sim->read(i));
        w.write(truth.back());
      }
      w.finish();
    }
    ASSERT_TRUE(std::filesystem::exists(dir.str() + "/rings/000000.bin"));
    auto with_file =
        makeSource(reg, "semantickitti",
                   "{path: " + dir.str() + ", label_map: " + sim_map + ", use_images: true}", ctx);
    auto recovered = makeSource(
        reg, "semantickitti",
        "{path: " + dir.str() + ", use_labels: false, ring_method: recover, ring_z_offset_m: 0}",
        ctx);
    ASSERT_EQ(with_file->size(), truth.size());
    std::size_t total = 0, exact = 0;
    for (std::size_t i = 0; i < truth.size(); ++i) {
      const Frame& t = truth[i];
      const Frame f = with_file->read(i);
      ASSERT_EQ(f.points.size(), t.points.size());
      EXPECT_EQ(f.points.x, t.points.x);
      EXPECT_EQ(f.points.ring, t.points.ring);
      EXPECT_EQ(f.truth.raw, t.truth.raw);
      EXPECT_EQ(f.truth.label, t.truth.label);
      ASSERT_TRUE(f.pose && t.pose);
      EXPECT_TRUE(f.pose->isApprox(*t.pose, 1e-6));
      EXPECT_NEAR(f.timestamp_s, t.timestamp_s, 1e-6);
      ASSERT_EQ(f.cameras.size(), 1u);
      ASSERT_FALSE(t.cameras.empty());
      const Eigen::Vector3d p(t.points.x[0], t.points.y[0], t.points.z[0]);
      for (const Eigen::Vector3d& q :
           {p, Eigen::Vector3d(10, 1, -1), Eigen::Vector3d(20, -3, 0.5)}) {
        const auto a = f.cameras[0].model.projectUnbounded(q),
                   b = t.cameras[0].model.projectUnbounded(q);
        ASSERT_EQ(a.has_value(), b.has_value());
        if (a) EXPECT_LT((*a - *b).norm(), 1e-3);
      }
      const Frame r = recovered->read(i);
      ASSERT_EQ(r.points.ring.size(), t.points.ring.size());
      for (std::size_t k = 0; k < r.points.size(); ++k)
        exact += r.points.ring[k] == t.points.ring[k];
      total += r.points.size();
    }
    const double acc = double(exact) / total;
    std::printf(
        "simulator (%s order) -> KITTI files -> recovered rings: %.4f exact of %zu points\n",
        order.c_str(), acc, total);
    EXPECT_GT(acc, 0.98) << order;
  }
}

}  // namespace
}  // namespace terramrf
