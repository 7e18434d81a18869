#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "plugin_harness.hpp"
#include "terramrf/errors.hpp"

namespace terramrf {

namespace {
std::string writeModel(const test::TempDir& d) {
  const std::string p = d.str() + "/m.yaml";
  std::ofstream(p) << "classes:\n"
                      "  road:     {f: {mean: 0.0, sigma: 0.1}}\n"
                      "  rough:    {f: {mean: 1.0, sigma: 0.5}}\n"
                      "  obstacle: {f: {mean: 5.0, sigma: 2.0}}\n";
  return p;
}
}  // namespace

TEST(PottsGaussian, UnaryIsAlphaTimesEq11) {
  test::TempDir d;
  test::StageHarness h;
  h.frame.points.push_back(1.1f, 1.1f, -1.7f, 0);
  h.bin();
  h.grid.add("f")[h.geom.cellOf(1.1, 1.1)] = 1.0f;
  h.make("potts_gaussian", "{model: " + writeModel(d) + ", features: [f], alpha: 2.0}")->process(h.ctx);
  const EnergyModel& em = h.ctx.energy;
  ASSERT_EQ(em.numLabels(), 3);
  EXPECT_EQ(em.active[0], labels::kRoad);
  const int c = h.geom.cellOf(1.1, 1.1);
  auto eq11 = [](double f, double mu, double s) {
    return (f - mu) * (f - mu) / (2 * s * s) + std::log(std::sqrt(2 * M_PI) * s);
  };
  EXPECT_NEAR(em.unary[c * 3 + 0], 2 * eq11(1, 0, 0.1), 1e-3);
  EXPECT_NEAR(em.unary[c * 3 + 1], 2 * eq11(1, 1, 0.5), 1e-5);
  EXPECT_NEAR(em.unary[c * 3 + 2], 2 * eq11(1, 5, 2.0), 1e-5);
  EXPECT_EQ(em.initial[c], 1);  // rough has the lowest unary
  EXPECT_EQ(em.fixed[c], 0);
  EXPECT_EQ(em.fixed[h.geom.cellOf(-3, -3)], 1);  // no points: fixed unknown
  EXPECT_FLOAT_EQ(em.beta, 0.8f);
  EXPECT_FLOAT_EQ(em.beta_diagonal, 0.8f);
}

TEST(PottsGaussian, ClassCostShiftsTheUnaryAndCanFlipTheStart) {
  test::TempDir d;
  test::StageHarness h;
  h.frame.points.push_back(1.1f, 1.1f, -1.7f, 0);
  h.bin();
  h.grid.add("f")[h.geom.cellOf(1.1, 1.1)] = 1.0f;
  const std::string m = writeModel(d);
  const int c = h.geom.cellOf(1.1, 1.1);
  h.make("potts_gaussian", "{model: " + m + ", features: [f]}")->process(h.ctx);
  const float base_obstacle = h.ctx.energy.unary[c * 3 + 2];
  EXPECT_EQ(h.ctx.energy.initial[c], 1);
  // Obstacle's energy is 3.39 above rough's (3.61 vs 0.23): a cost of −4 makes it the cheapest.
  h.make("potts_gaussian", "{model: " + m + ", features: [f], class_cost: [0, 0, -4]}")->process(h.ctx);
  EXPECT_NEAR(h.ctx.energy.unary[c * 3 + 2], base_obstacle - 4, 1e-5);
  EXPECT_EQ(h.ctx.energy.initial[c], 2);
  try {
    h.make("potts_gaussian", "{model: " + m + ", features: [f], class_cost: [0, -1]}");
    FAIL() << "expected an error";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("class_cost"), std::string::npos) << e.what();
  }
}

TEST(PottsGaussian, ClassCostIsAddedAfterTheAlphaWeighting) {
  // docs/energy.md: unary_k = α·E_f + cost_k, so α does not scale the cost.
  test::TempDir d;
  test::StageHarness h;
  h.frame.points.push_back(1.1f, 1.1f, -1.7f, 0);
  h.bin();
  h.grid.add("f")[h.geom.cellOf(1.1, 1.1)] = 1.0f;
  const std::string m = writeModel(d);
  const int c = h.geom.cellOf(1.1, 1.1);
  h.make("potts_gaussian", "{model: " + m + ", features: [f], alpha: 2.0}")->process(h.ctx);
  const std::vector<float> scaled(h.ctx.energy.unary.begin() + c * 3,
                                  h.ctx.energy.unary.begin() + c * 3 + 3);
  h.make("potts_gaussian",
         "{model: " + m + ", features: [f], alpha: 2.0, class_cost: [0.5, 0, -1]}")
      ->process(h.ctx);
  EXPECT_NEAR(h.ctx.energy.unary[c * 3 + 0], scaled[0] + 0.5, 1e-5);
  EXPECT_NEAR(h.ctx.energy.unary[c * 3 + 1], scaled[1], 1e-5);
  EXPECT_NEAR(h.ctx.energy.unary[c * 3 + 2], scaled[2] - 1, 1e-5);
}

TEST(PottsGaussian, NaNFeatureDoesNotVoteAndPreclassSetsStart) {
  test::TempDir d;
  test::StageHarness h;
  h.frame.points.push_back(1.1f, 1.1f, -1.7f, 0);
  h.bin();
  h.grid.add("f");  // all NaN
  Layer& pre = h.grid.add("preclass", 0);
  pre[h.geom.cellOf(1.1, 1.1)] = 2;  // obstacle
  h.make("potts_gaussian", "{model: " + writeModel(d) + ", features: [f], preclass_layer: preclass}")
      ->process(h.ctx);
  const int c = h.geom.cellOf(1.1, 1.1);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(h.ctx.energy.unary[c * 3 + k], 0.f);
  EXPECT_EQ(h.ctx.energy.initial[c], 2);
}

// Evidence layers (the temporal-fusion slot): a cost per class added where every layer has a
// number; a cell without points but with evidence is classified, one without either stays
// unknown.
TEST(PottsGaussian, EvidenceAddsToTheUnaryAndClassifiesCellsWithoutPoints) {
  test::TempDir d;
  test::StageHarness h;
  h.frame.points.push_back(1.1f, 1.1f, -1.7f, 0);
  h.bin();
  const int with_points = h.geom.cellOf(1.1, 1.1);
  const int empty_with = h.geom.cellOf(1.6, 1.1);  // no points, evidence for obstacle
  const int empty_part = h.geom.cellOf(2.1, 1.1);  // no points, one layer NaN
  const int empty_none = h.geom.cellOf(-3, -3);    // no points, no evidence
  h.grid.add("f")[with_points] = 1.0f;
  Layer& e_road = h.grid.add("ev.road");
  Layer& e_rough = h.grid.add("ev.rough");
  Layer& e_obst = h.grid.add("ev.obstacle");
  for (int c : {with_points, empty_with}) {
    e_road[c] = 3.f;
    e_rough[c] = 2.f;
    e_obst[c] = 0.5f;
  }
  e_road[empty_part] = 0.f;
  e_rough[empty_part] = 1.f;
  const std::string m = writeModel(d);
  h.make("potts_gaussian", "{model: " + m + ", features: [f], class_cost: [0, 0, -0.25]}")
      ->process(h.ctx);
  const std::vector<float> plain(h.ctx.energy.unary.begin() + with_points * 3,
                                 h.ctx.energy.unary.begin() + with_points * 3 + 3);
  auto s = h.make("potts_gaussian", "{model: " + m +
                                        ", features: [f], class_cost: [0, 0, -0.25], "
                                        "evidence_layers: [ev.road, ev.rough, ev.obstacle]}");
  EXPECT_EQ(s->reads(),
            (std::vector<std::string>{"f", "@points", "ev.road", "ev.rough", "ev.obstacle"}));
  s->process(h.ctx);
  const EnergyModel& em = h.ctx.energy;
  EXPECT_NEAR(em.unary[with_points * 3 + 0], plain[0] + 3.f, 1e-5);
  EXPECT_NEAR(em.unary[with_points * 3 + 1], plain[1] + 2.f, 1e-5);
  EXPECT_NEAR(em.unary[with_points * 3 + 2], plain[2] + 0.5f, 1e-5);
  EXPECT_EQ(em.fixed[with_points], 0);
  // No feature term where there are no points: the evidence and the class cost.
  EXPECT_EQ(em.fixed[empty_with], 0);
  EXPECT_FLOAT_EQ(em.unary[empty_with * 3 + 0], 3.f);
  EXPECT_FLOAT_EQ(em.unary[empty_with * 3 + 1], 2.f);
  EXPECT_FLOAT_EQ(em.unary[empty_with * 3 + 2], 0.25f);
  EXPECT_EQ(em.initial[empty_with], 2);
  EXPECT_EQ(em.fixed[empty_part], 1);
  EXPECT_EQ(em.fixed[empty_none], 1);
  EXPECT_EQ(h.ctx.metrics.at("potts_gaussian.cells_from_evidence"), 1.0);

  // Every optimiser then labels that cell; a cell with neither stays unknown.
  for (const char* opt : {"icm", "gibbs", "alpha_expansion"}) {
    h.make(opt)->process(h.ctx);
    EXPECT_EQ(h.grid.labels()[empty_with], labels::kObstacle) << opt;
    EXPECT_EQ(h.grid.labels()[empty_none], labels::kUnknown) << opt;
    EXPECT_EQ(h.grid.labels()[empty_part], labels::kUnknown) << opt;
  }

  // An infinite cost is the producing stage's error, named with the layer and the cell.
  e_rough[empty_with] = INFINITY;
  try {
    s->process(h.ctx);
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(
        std::string(e.what()).find("evidence layer 'ev.rough' holds +inf in cell (row 23, col "
                                   "22) at x = 1.75 m, y = 1.25 m"),
        std::string::npos)
        << e.what();
  }
  // One layer per class, in the order of `classes`.
  try {
    h.make("potts_gaussian", "{model: " + m + ", features: [f], evidence_layers: [ev.road]}");
    FAIL() << "expected an error";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("give one layer per class of `classes` (3, in its "
                                         "order: road, rough, obstacle), or none"),
              std::string::npos)
        << e.what();
  }
}

TEST(PottsGaussian, ModelForOtherFeaturesNamesTheFile) {
  test::TempDir d;
  test::StageHarness h;
  const std::string m = writeModel(d);
  try {
    h.make("potts_gaussian", "{model: " + m + ", features: [f, g]}");
    FAIL();
  } catch (const std::runtime_error& e) {
    const std::string s = e.what();
    EXPECT_NE(s.find("feature 'g' is not in model " + m), std::string::npos) << s;
  }
  std::ofstream(d.str() + "/bad.yaml") << "classes:\n  road: {f: {mean: 0, sigma: -1}}\n";
  try {
    h.make("potts_gaussian", "{model: " + d.str() + "/bad.yaml, features: [f]}");
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.yaml:2:"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("sigma must be a finite number > 0"), std::string::npos)
        << e.what();
  }
}

// A class may be a mixture: its energy is −log Σ w_m N_m (eq. 11 per component), and a feature
// without data does not vote in any component.
TEST(PottsGaussian, MixtureEnergyIsMinusLogOfTheWeightedSum) {
  test::TempDir d;
  const std::string p = d.str() + "/mix.yaml";
  std::ofstream(p)
      << "classes:\n"
         "  road:  {f: {mean: 0.0, sigma: 0.1}, g: {mean: 0, sigma: 1}}\n"
         "  rough: {f: {mean: 1.0, sigma: 0.5}, g: {mean: 0, sigma: 1}}\n"
         "  obstacle:\n"
         "    components:\n"
         "      - {weight: 0.25, features: {f: {mean: 0.3, sigma: 0.1}, g: {mean: 0, sigma: 1}}}\n"
         "      - {weight: 0.75, features: {f: {mean: 5.0, sigma: 2.0}, g: {mean: 3, sigma: 1}}}\n";
  test::StageHarness h;
  h.frame.points.push_back(1.1f, 1.1f, -1.7f, 0);
  h.frame.points.push_back(3.1f, 3.1f, -1.7f, 0);
  h.bin();
  const int c1 = h.geom.cellOf(1.1, 1.1), c2 = h.geom.cellOf(3.1, 3.1);
  h.grid.add("f")[c1] = 0.35f;
  h.grid.layer("f")[c2] = 0.35f;
  h.grid.add("g")[c1] = 1.0f;  // g is NaN in c2
  h.make("potts_gaussian", "{model: " + p + ", features: [f, g]}")->process(h.ctx);
  auto n = [](double x, double mu, double s) {
    return std::exp(-(x - mu) * (x - mu) / (2 * s * s)) / (std::sqrt(2 * M_PI) * s);
  };
  const double e1 =
      -std::log(0.25 * n(0.35, 0.3, 0.1) * n(1, 0, 1) + 0.75 * n(0.35, 5, 2) * n(1, 3, 1));
  const double e2 = -std::log(0.25 * n(0.35, 0.3, 0.1) + 0.75 * n(0.35, 5, 2));
  EXPECT_NEAR(h.ctx.energy.unary[c1 * 3 + 2], e1, 1e-4);
  EXPECT_NEAR(h.ctx.energy.unary[c2 * 3 + 2], e2, 1e-4);
  EXPECT_NEAR(h.ctx.energy.unary[c2 * 3 + 0], -std::log(n(0.35, 0, 0.1)), 1e-4);  // one component
}

TEST(PottsGaussian, BadMixturesNameTheFileAndLine) {
  test::TempDir d;
  test::StageHarness h;
  const std::string base =
      "classes:\n  road: {f: {mean: 0, sigma: 1}}\n  rough: {f: {mean: 1, sigma: 1}}\n";
  struct Case {
    const char *obstacle, *expect;
  };
  for (const Case& c :
       {Case{"  obstacle: {components: [{weight: 0.5, features: {f: {mean: 0, sigma: 1}}},"
             " {weight: 0.4, features: {f: {mean: 2, sigma: 1}}}]}\n",
             "component weights sum to 0.9"},
        Case{"  obstacle: {components: [{weight: 1.0, features: {g: {mean: 0, sigma: 1}}}]}\n",
             "feature 'f' is not in model"},
        Case{"  obstacle: {components: [{weight: 0, features: {f: {mean: 0, sigma: 1}}},"
             " {weight: 1, features: {f: {mean: 0, sigma: 1}}}]}\n",
             "component weight must be > 0"},
        Case{"  obstacle: {components: []}\n", "expected a list of {weight, features}"},
        // Non-finite numbers made every cell's energy NaN or infinite for the class.
        Case{"  obstacle: {f: {mean: .nan, sigma: 1}}\n",
             "bad.yaml:4:17: obstacle.f: mean must be a finite number, got nan"},
        Case{"  obstacle: {f: {mean: 1, sigma: .inf}}\n",
             "bad.yaml:4:17: obstacle.f: sigma must be a finite number > 0, got inf"},
        Case{"  obstacle: {components: [{weight: .nan, features: {f: {mean: 0, sigma: 1}}}]}\n",
             "component weight must be > 0"},
        // A class whose value is not a map of features (a list, a number).
        Case{"  obstacle: [2, 1]\n",
             "bad.yaml:4:13: class 'obstacle' must map features to {mean, sigma}"},
        Case{"  obstacle: 2\n",
             "bad.yaml:4:13: class 'obstacle' must map features to {mean, sigma}"},
        // A component without a weight, or one that is not a number.
        Case{"  obstacle: {components: [{features: {f: {mean: 0, sigma: 1}}}]}\n",
             "bad.yaml:4:27: obstacle.components: missing 'weight'"},
        Case{"  obstacle: {components: [{weight: half, features: {f: {mean: 0, sigma: 1}}}]}\n",
             "bad.yaml:4:36: obstacle.components.weight: expected a number, got 'half'"},
        // Numbers in messages as written, not as six fixed decimals ("got -0.000000").
        Case{"  obstacle: {f: {mean: 1, sigma: -1e-9}}\n",
             "obstacle.f: sigma must be a finite number > 0, got -1e-09"},
        Case{"  obstacle: {f: {mean: abc, sigma: 1}}\n",
             "bad.yaml:4:24: obstacle.f.mean: expected a number, got 'abc'"},
        Case{"  obstacle: {f: {sigma: 1}}\n", "bad.yaml:4:17: obstacle.f: missing 'mean'"},
        // A misspelt or misplaced key used to be ignored without a word.
        Case{"  obstacle: {f: {mean: 1, sigma: 1, sigmaa: 5}}\n",
             "bad.yaml: line 4:37: unknown key 'sigmaa' in feature 'obstacle.f' (did you mean "
             "'sigma'?); expected one of: mean, sigma"},
        Case{"  obstacle: {f: {mean: 99, sigma: 1}, components: [{weight: 1, features: {f: "
             "{mean: 0, sigma: 1}}}]}\n",
             "unknown key 'f' in class 'obstacle' (a class with 'components' has nothing else)"},
        Case{"  obstacle: {components: [{weight: 1, featurs: {f: {mean: 0, sigma: 1}}}]}\n",
             "unknown key 'featurs' in a component of class 'obstacle' (did you mean "
             "'features'?)"},
        // A component without features.
        Case{"  obstacle: {components: [{weight: 1}]}\n",
             "bad.yaml:4:27: obstacle.components: each needs 'features:'"},
        // A repeated class would be ignored: the second road's statistics never used.
        Case{"  obstacle: {f: {mean: 2, sigma: 1}}\n  road: {f: {mean: 5, sigma: 1}}\n",
             "bad.yaml: line 5:3: duplicate key 'road' (first at line 2)"},
        Case{"  obstacle: {f: {mean: 2, sigma: 1}, f: {mean: 3, sigma: 1}}\n", "duplicate key 'f'"},
        // Found by fuzzing: yaml-cpp's own message, without the file, came out of these.
        Case{"  obstacle: {f: {mean: 2, sigma: [1\n",
             "bad.yaml: line 5:1: YAML syntax error: end of sequence flow not found"},
        Case{"  ? [obstacle]\n  : {f: {mean: 2, sigma: 1}}\n",
             "bad.yaml: line 4:5: not a model file"}}) {
    const std::string p = d.str() + "/bad.yaml";
    std::ofstream(p) << base << c.obstacle;
    try {
      h.make("potts_gaussian", "{model: " + p + ", features: [f]}");
      ADD_FAILURE() << "accepted " << c.obstacle;
    } catch (const std::exception& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(c.expect), std::string::npos) << what;
      EXPECT_NE(what.find("bad.yaml"), std::string::npos) << what;
    }
  }
}

// `classes` names the labels the optimiser may assign: each must be a class of the label set
// (not 'unknown', which marks cells without data) and have an entry in the model.
TEST(PottsGaussian, ClassesOutsideTheLabelSetOrTheModelAreNamed) {
  test::TempDir d;
  test::StageHarness h;
  const std::string m = writeModel(d);
  struct Case {
    std::string classes, expect;
  };
  for (const Case& c :
       {Case{"[road, grass]",
             "parameter 'classes': 'grass' is not a class of the label set (or is 'unknown')"},
        Case{"[unknown, road]",
             "parameter 'classes': 'unknown' is not a class of the label set (or is 'unknown')"}}) {
    try {
      h.make("potts_gaussian", "{model: " + m + ", features: [f], classes: " + c.classes + "}");
      ADD_FAILURE() << "accepted classes " << c.classes;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(c.expect), std::string::npos) << e.what();
    }
  }
  // A class of the label set the model was not trained for.
  const std::string two = d.str() + "/two.yaml";
  std::ofstream(two)
      << "classes:\n  road: {f: {mean: 0, sigma: 1}}\n  rough: {f: {mean: 1, sigma: 1}}\n";
  try {
    h.make("potts_gaussian", "{model: " + two + ", features: [f]}");
    FAIL() << "accepted a model without obstacle";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("parameter 'model': " + two +
                                         " has no entry for class 'obstacle'"),
              std::string::npos)
        << e.what();
  }
  // Listing only the classes the model has works.
  EXPECT_NO_THROW(
      h.make("potts_gaussian", "{model: " + two + ", features: [f], classes: [road, rough]}"));
}

TEST(PottsGaussian, AFileThatIsNoModelNamesTheFile) {
  test::TempDir d;
  test::StageHarness h;
  for (const char* text : {"abc\n", "[1, 2]\n", "classes: 3\n"}) {
    std::ofstream(d.str() + "/m.yaml") << text;
    try {
      h.make("potts_gaussian", "{model: " + d.str() + "/m.yaml, features: [f]}");
      ADD_FAILURE() << "accepted " << text;
    } catch (const std::exception& e) {
      EXPECT_NE(std::string(e.what()).find(d.str() + "/m.yaml: expected a"), std::string::npos)
          << e.what();
    }
  }
}

}  // namespace terramrf

namespace terramrf {

// With a config's own label set the energy must offer every class of it: a fixed default of road,
// rough and obstacle left the extra class of such a set unpredicted, without a word.
TEST(PottsGaussian, DefaultClassesAreTheLabelSetsAndARepeatIsRefused) {
  test::TempDir d;
  test::StageHarness h;
  h.labels = LabelSet({{"unknown", {0, 0, 0}},
                       {"road", {128, 128, 128}},
                       {"sidewalk", {255, 0, 255}},
                       {"rough", {139, 90, 43}},
                       {"obstacle", {220, 30, 30}}});
  h.frame.points.push_back(1.1f, 1.1f, -1.7f, 0);
  h.bin();
  h.grid.add("f")[h.geom.cellOf(1.1, 1.1)] = 0.5f;
  const std::string m = d.str() + "/m.yaml";
  std::ofstream(m) << "classes:\n"
                      "  road:     {f: {mean: 0.0, sigma: 0.1}}\n"
                      "  sidewalk: {f: {mean: 0.5, sigma: 0.1}}\n"
                      "  rough:    {f: {mean: 1.0, sigma: 0.5}}\n"
                      "  obstacle: {f: {mean: 5.0, sigma: 2.0}}\n";
  h.make("potts_gaussian", "{model: " + m + ", features: [f]}")->process(h.ctx);
  const EnergyModel& em = h.ctx.energy;
  ASSERT_EQ(em.numLabels(), 4);
  for (int k = 0; k < 4; ++k) EXPECT_EQ(em.active[k], k + 1) << k;  // id order
  EXPECT_EQ(em.active[em.initial[h.geom.cellOf(1.1, 1.1)]], 2);     // sidewalk fits best

  // A class missing from the model is named, as for an explicit list.
  std::ofstream(m) << "classes:\n  road: {f: {mean: 0, sigma: 1}}\n  rough: {f: {mean: 1, sigma: "
                      "1}}\n  obstacle: {f: {mean: 5, sigma: 1}}\n";
  try {
    h.make("potts_gaussian", "{model: " + m + ", features: [f]}");
    FAIL() << "a model without the label set's 'sidewalk' was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("has no entry for class 'sidewalk'"), std::string::npos)
        << e.what();
  }
  try {
    h.make("potts_gaussian", "{model: " + m + ", features: [f], classes: [road, rough, road]}");
    FAIL() << "a class listed twice was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("'road' is listed twice"), std::string::npos) << e.what();
  }
  // A repeated feature would count twice in eq. 11 (it used to be accepted).
  try {
    h.make("potts_gaussian", "{model: " + m + ", features: [f, f]}");
    FAIL() << "a feature listed twice was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("parameter 'features': 'f' is listed twice"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace terramrf

namespace terramrf {

namespace {
/// A model of feature f (three classes) learnt on f computed as `origin` says, in `d`.
std::string modelWithOrigin(const test::TempDir& d, const std::string& origin) {
  const std::string m = d.str() + "/m.yaml";
  std::ofstream(m) << "feature_origins:\n  f: " << origin << "\n"
                   << "classes:\n"
                      "  road:     {f: {mean: 0.0, sigma: 0.1}}\n"
                      "  rough:    {f: {mean: 1.0, sigma: 0.5}}\n"
                      "  obstacle: {f: {mean: 5.0, sigma: 2.0}}\n";
  return m;
}
}  // namespace

// A model records how each feature was computed; run with features computed otherwise (another
// parameter, here or in an input's stage, or another stage), it is refused, naming each
// difference. Same origins, a model that records none, or check_feature_origins: false: used.
TEST(PottsGaussian, AModelLearntOnFeaturesComputedOtherwiseIsRefused) {
  test::TempDir d;
  const std::string rough =
      "{stage: roughness, params: {layer: roughness, window: 2, max_jump_m: 0.5}}";
  const std::string learnt =
      "{stage: log_transform, params: {input: roughness, offset: 0.001}, "
      "inputs: {roughness: " +
      rough + "}}";
  const std::string m = modelWithOrigin(d, learnt);
  test::StageHarness h;
  std::map<std::string, std::string> here{{"f", learnt}};
  h.layer_origins = &here;
  EXPECT_NO_THROW(h.make("potts_gaussian", "{model: " + m + ", features: [f]}"));

  here["f"] =
      "{stage: log_transform, params: {input: roughness, offset: 0.01}, inputs: "
      "{roughness: {stage: roughness, params: {layer: roughness, window: 4, max_jump_m: "
      "0.5}}}}";
  try {
    h.make("potts_gaussian", "{model: " + m + ", features: [f]}");
    FAIL() << "a model learnt on other features was accepted";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    for (const char* want : {"was learnt on features computed otherwise than here:",
                             "feature 'f': offset: 0.01 here, 0.001 in the model",
                             "feature 'f': input 'roughness': window: 4 here, 2 in the model",
                             "check_feature_origins: false uses it anyway"})
      EXPECT_NE(what.find(want), std::string::npos) << want << "\n" << what;
    EXPECT_EQ(what.find("max_jump_m"), std::string::npos) << what;  // the same on both sides
  }
  here["f"] = rough;
  try {
    h.make("potts_gaussian", "{model: " + m + ", features: [f]}");
    FAIL() << "a model learnt on another stage's layer was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(
                  "feature 'f': written by roughness here, by log_transform in the model"),
              std::string::npos)
        << e.what();
  }
  EXPECT_NO_THROW(
      h.make("potts_gaussian", "{model: " + m + ", features: [f], check_feature_origins: false}"));
  h.layer_origins = nullptr;  // configured outside a pipeline: nothing to compare with
  EXPECT_NO_THROW(h.make("potts_gaussian", "{model: " + m + ", features: [f]}"));
  h.layer_origins = &here;
  EXPECT_NO_THROW(h.make("potts_gaussian", "{model: " + writeModel(d) + ", features: [f]}"));
}

// Layers received with their origins from a live stream (Frame::layer_origins, unknown when the
// stage is configured) are checked per frame: a scan whose feature came computed otherwise fails,
// naming the scan and the difference; the same origins, or none, run.
TEST(PottsGaussian, AFrameWhoseLayersCameComputedOtherwiseFails) {
  test::TempDir d;
  const std::string learnt = "{stage: roughness, params: {layer: f, window: 2}}";
  const std::string m = modelWithOrigin(d, learnt);
  test::StageHarness h;
  h.frame.id = "000007";
  h.frame.source_path = "udpm://239.255.76.67:7667";
  h.bin();
  h.grid.add("f", 0.5f);
  auto s = h.make("potts_gaussian", "{model: " + m + ", features: [f]}");
  EXPECT_NO_THROW(s->process(h.ctx));  // no origins came
  h.frame.layer_origins["f"] = learnt;
  EXPECT_NO_THROW(s->process(h.ctx));
  h.frame.layer_origins["f"] = "{stage: roughness, params: {layer: f, window: 3}}";
  try {
    s->process(h.ctx);
    FAIL() << "a frame of layers computed otherwise was classified";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "udpm://239.255.76.67:7667");
    const std::string what = e.what();
    for (const char* want : {"scan '000007': its layers came computed otherwise than model ",
                             "feature 'f': window: 3 here, 2 in the model"})
      EXPECT_NE(what.find(want), std::string::npos) << want << "\n" << what;
  }
  EXPECT_NO_THROW(
      h.make("potts_gaussian", "{model: " + m + ", features: [f], check_feature_origins: false}")
          ->process(h.ctx));
  // Known when the stage was configured (a stage of this run rewrote the received layer): checked
  // then, against the run's origin, and not against the sender's that the frame still gives.
  std::map<std::string, std::string> run_origins{{"f", learnt}};
  h.layer_origins = &run_origins;
  EXPECT_NO_THROW(h.make("potts_gaussian", "{model: " + m + ", features: [f]}")->process(h.ctx));
}

// Cell sizes are named as a config gives them. The record holds yaml-cpp's emission of the
// double, 0.10000000000000001 for 0.1, and that was repeated: "cells of 0.10000000000000001 m
// here".
TEST(PottsGaussian, ACellSizeDifferenceNamesBothSizesAsWritten) {
  test::TempDir d;
  const std::string m = d.str() + "/m.yaml";
  std::ofstream(m) << "feature_origins:\n  f: {stage: height_difference, cell_m: 0.5, params: "
                      "{min_points: 1}}\n"
                   << "classes:\n"
                      "  road:     {f: {mean: 0.0, sigma: 0.1}}\n"
                      "  rough:    {f: {mean: 1.0, sigma: 0.5}}\n"
                      "  obstacle: {f: {mean: 5.0, sigma: 2.0}}\n";
  test::StageHarness h;
  // As the loader records a layer's origin on cells of 0.1 m (yaml-cpp's emitter).
  std::map<std::string, std::string> here{
      {"f", "{stage: height_difference, cell_m: 0.10000000000000001, params: {min_points: 1}}"}};
  h.layer_origins = &here;
  try {
    h.make("potts_gaussian", "{model: " + m + ", features: [f]}");
    FAIL() << "a model of 0.5 m cells was used on 0.1 m cells";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("feature 'f': cells of 0.1 m here, 0.5 m in the model"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace terramrf

namespace terramrf {

namespace {
/// The message of the error making `params` fails with, or "" when it is accepted.
std::string refusal(test::StageHarness& h, const std::string& params) {
  try {
    h.make("potts_gaussian", params);
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}
}  // namespace

// `class_cost: .inf` (or 1e39, infinite once in single precision) used to pass: α-expansion then
// accepted no move and Gibbs returned its start with energy −inf, exit status 0.
TEST(PottsGaussian, ANonFiniteOrHugeClassCostIsRefused) {
  test::TempDir d;
  test::StageHarness h;
  const std::string m = writeModel(d);
  for (const char* cost : {".inf", "-.inf", "1e39", ".nan"}) {
    const std::string what =
        refusal(h, "{model: " + m + ", features: [f], class_cost: [0, " + cost + ", 0]}");
    EXPECT_NE(what.find("class_cost"), std::string::npos) << cost << ": " << what;
    EXPECT_NE(what.find("expected in [-1000000, 1000000]"), std::string::npos)
        << cost << ": " << what;
  }
  EXPECT_EQ(refusal(h, "{model: " + m + ", features: [f], class_cost: [0, -1e6, 1e6]}"), "");
}

// σ = 1e-25 passed the loader (finite, > 0) but 1/(2σ²) is infinite in the single-precision
// unaries: a cell whose feature equals the mean got NaN, and the class was never chosen.
TEST(PottsGaussian, AModelSigmaOutsideSinglePrecisionIsRefused) {
  test::TempDir d;
  test::StageHarness h;
  for (const char* entry :
       {"{mean: 0, sigma: 1e-25}", "{mean: 0, sigma: 1e20}", "{mean: 1e39, sigma: 1}"}) {
    const std::string p = d.str() + "/tiny.yaml";
    std::ofstream(p) << "classes:\n  road: {f: " << entry
                     << "}\n  rough: {f: {mean: 1, sigma: 1}}\n"
                        "  obstacle: {f: {mean: 5, sigma: 2}}\n";
    const std::string what = refusal(h, "{model: " + p + ", features: [f]}");
    EXPECT_NE(what.find("tiny.yaml: road.f: mean "), std::string::npos) << entry << ": " << what;
    EXPECT_NE(what.find("cannot be computed with in single precision"), std::string::npos) << what;
  }
}

// A feature astronomically far from every mean (or infinite) gives a finite unary, also with
// α = 0, where inf · 0 used to be NaN.
TEST(PottsGaussian, UnariesStayFiniteForExtremeFeatures) {
  test::TempDir d;
  const std::string m = writeModel(d);
  for (const char* alpha : {"1", "0"}) {
    test::StageHarness h;
    h.frame.points.push_back(1.1f, 1.1f, -1.7f, 0);
    h.frame.points.push_back(-1.1f, 1.1f, -1.7f, 0);
    h.bin();
    const int a = h.geom.cellOf(1.1, 1.1), b = h.geom.cellOf(-1.1, 1.1);
    h.grid.add("f")[a] = INFINITY;
    h.grid.layer("f")[b] = 1e30f;
    h.make("potts_gaussian", std::string("{model: ") + m + ", features: [f], alpha: " + alpha + "}")
        ->process(h.ctx);
    for (int c : {a, b})
      for (int k = 0; k < 3; ++k)
        EXPECT_TRUE(std::isfinite(h.ctx.energy.unary[c * 3 + k]))
            << "alpha " << alpha << " cell " << c << " class " << k << ": "
            << h.ctx.energy.unary[c * 3 + k];
    EXPECT_TRUE(std::isfinite(h.ctx.energy.energy(h.ctx.energy.initial)));
  }
}

// A misspelt top-level key (`feature_origin:`) switched the origin check off without a word.
TEST(PottsGaussian, AnUnknownTopLevelKeyOfTheModelIsRefused) {
  test::TempDir d;
  test::StageHarness h;
  const std::string p = d.str() + "/typo.yaml";
  std::ofstream(p) << "feature_origin:\n  f: {stage: roughness}\nclasses:\n"
                      "  road: {f: {mean: 0, sigma: 1}}\n  rough: {f: {mean: 1, sigma: 1}}\n"
                      "  obstacle: {f: {mean: 5, sigma: 2}}\n";
  const std::string what = refusal(h, "{model: " + p + ", features: [f]}");
  EXPECT_NE(what.find("typo.yaml: line 1:1: unknown key 'feature_origin' in the model file (did "
                      "you mean 'feature_origins'?); expected one of: provenance, trained_from, "
                      "feature_origins, classes"),
            std::string::npos)
      << what;
}

// A folder given as the model read as "basic_filebuf::underflow error reading the file".
TEST(PottsGaussian, AFolderAsTheModelIsNamedAsSuch) {
  test::TempDir d;
  test::StageHarness h;
  const std::string what = refusal(h, "{model: " + d.str() + ", features: [f]}");
  EXPECT_NE(what.find(d.str() + ": is a folder; expected a YAML file"), std::string::npos) << what;
}

// A stage that reads no layer records no `inputs:`; comparing it with a run where the feature's
// stage does read one used to end in "the model's record of it cannot be read".
TEST(PottsGaussian, AnOriginRecordWithoutInputsIsComparedNotCalledUnreadable) {
  test::TempDir d;
  const std::string m = d.str() + "/m.yaml";
  std::ofstream(m) << "feature_origins:\n  f: {stage: log_transform, params: {input: roughness}}\n"
                   << "classes:\n"
                      "  road:     {f: {mean: 0.0, sigma: 0.1}}\n"
                      "  rough:    {f: {mean: 1.0, sigma: 0.5}}\n"
                      "  obstacle: {f: {mean: 5.0, sigma: 2.0}}\n";
  test::StageHarness h;
  std::map<std::string, std::string> here{
      {"f",
       "{stage: log_transform, params: {input: roughness}, inputs: {roughness: {stage: "
       "roughness, params: {window: 2}}}}"}};
  h.layer_origins = &here;
  std::string what = refusal(h, "{model: " + m + ", features: [f]}");
  EXPECT_NE(what.find("feature 'f': input 'roughness': computed here, not recorded in the model"),
            std::string::npos)
      << what;
  EXPECT_EQ(what.find("cannot be read"), std::string::npos) << what;
  // And the other way round: no `params` here.
  here["f"] = "{stage: log_transform}";
  what = refusal(h, "{model: " + m + ", features: [f]}");
  EXPECT_NE(what.find("feature 'f': input: (not set) here, roughness in the model"),
            std::string::npos)
      << what;
}

}  // namespace terramrf
