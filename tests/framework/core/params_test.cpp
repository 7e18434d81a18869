#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "terramrf/param_values.hpp"
#include "terramrf/plugin.hpp"
#include "test_support.hpp"

namespace terramrf {
namespace {

struct Demo : Stage {
  double cell_m = 0.5;
  int window = 5;
  bool flag = false;
  std::string mode = "a";
  std::vector<std::string> feats = {"x"};
  std::vector<double> weights;
  void declare(ParamDecl& d) override {
    d.add("cell_m", cell_m, "cell size").unit("m").range(0.1, 2);
    d.add("window", window, "window").range(1, 99);
    d.add("flag", flag, "a flag");
    d.add("mode", mode, "mode").choices({"a", "b"});
    d.add("features", feats, "features");
    d.add("weights", weights, "weights").min(0);
  }
  void configure(const PluginContext&) override {
    if (mode == "b" && window > 10) throw ParamError("window", "must be <= 10 in mode b");
  }
  void process(FrameContext&) override {}
};

}  // namespace

TEST(Params, DefaultsComeFromMembers) {
  Demo d;
  auto specs = declaredParams(d);
  ASSERT_EQ(specs.size(), 6u);
  EXPECT_EQ(std::get<double>(specs[0].default_value), 0.5);
  EXPECT_EQ(std::get<int64_t>(specs[1].default_value), 5);
  EXPECT_EQ(specs[0].unit, "m");
  EXPECT_EQ(toYaml(specs[4].default_value), "[x]");
}

TEST(Params, SetsValuesAndCallsConfigure) {
  Demo d;
  setParams(d, "{cell_m: 1.5, window: 7, flag: true, mode: b, features: [p, q], weights: [1, 2.5]}",
            PluginContext{});
  EXPECT_EQ(d.cell_m, 1.5);
  EXPECT_EQ(d.window, 7);
  EXPECT_TRUE(d.flag);
  EXPECT_EQ(d.mode, "b");
  EXPECT_EQ(d.feats, (std::vector<std::string>{"p", "q"}));
  EXPECT_EQ(d.weights, (std::vector<double>{1, 2.5}));
}

TEST(Params, CollectsEveryProblem) {
  Demo d;
  try {
    setParams(d, "{cell_m: 5, window: x, mode: c, windw: 3, weights: [-1]}", PluginContext{});
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("value 5 out of range: expected in [0.1, 2] m"), std::string::npos) << m;
    EXPECT_NE(m.find("'window': expected int, got 'x'"), std::string::npos) << m;
    EXPECT_NE(m.find("'c' is not one of: a, b"), std::string::npos) << m;
    EXPECT_NE(m.find("unknown parameter 'windw' (did you mean 'window'?)"), std::string::npos) << m;
    EXPECT_NE(m.find("'weights'"), std::string::npos) << m;
  }
}

// Limits and values are stated exactly: six significant digits made 4294967296 read 4.29497e+09
// and a range end 4194304 read 4.1943e+06.
TEST(Params, RangeMessagesStateNumbersExactly) {
  struct Big : Stage {
    int64_t seed = 1;
    double step_m = 0.5;
    void declare(ParamDecl& d) override {
      d.add("seed", seed, "seed").range(0, 4194304);
      d.add("step_m", step_m, "step").unit("m").range(0.000123457, 0.5);
    }
    void process(FrameContext&) override {}
  } b;
  try {
    setParams(b, "{seed: 4294967296, step_m: 0.0001234566}", PluginContext{});
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("value 4294967296 out of range: expected in [0, 4194304]"), std::string::npos)
        << m;
    EXPECT_NE(m.find("value 0.0001234566 out of range: expected in [0.000123457, 0.5] m"),
              std::string::npos)
        << m;
  }
}

// A number without declared bounds must still be finite: `class_cost: .inf` was accepted and
// made every optimiser's energy differences NaN. The message said "expected  energy".
TEST(Params, NonFiniteNumbersAreRefusedEvenWithoutARange) {
  struct Free : Stage {
    double cost = 0;
    std::vector<double> costs;
    void declare(ParamDecl& d) override {
      d.add("cost", cost, "a cost").unit("energy");
      d.add("costs", costs, "costs").unit("energy");
    }
    void process(FrameContext&) override {}
  } f;
  try {
    setParams(f, "{cost: .inf, costs: [0, -.inf]}", PluginContext{});
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("'cost': value inf out of range: expected a finite number (energy)"),
              std::string::npos)
        << m;
    EXPECT_NE(m.find("'costs': value -inf out of range: expected a finite number (energy)"),
              std::string::npos)
        << m;
  }
  setParams(f, "{cost: -1e300, costs: [1e300]}", PluginContext{});
  EXPECT_EQ(f.cost, -1e300);
}

// A list declared unique() refuses a repeated entry in the core, for every plugin alike (five
// plugins each had a check of their own; potts_gaussian's features and the camera lists of
// camera_fusion and fusion_overlay had none).
TEST(Params, AUniqueListRefusesARepeatedEntry) {
  struct Lists : Stage {
    std::vector<std::string> layers, free_list;
    void declare(ParamDecl& d) override {
      d.add("layers", layers, "layers").unique();
      d.add("free_list", free_list, "may repeat");
    }
    void process(FrameContext&) override {}
  } l;
  try {
    setParams(l, "{layers: [a, b, a]}", PluginContext{});
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(
        std::string(e.what()).find("parameter 'layers': 'a' is listed twice; list each entry once"),
        std::string::npos)
        << e.what();
  }
  EXPECT_NO_THROW(setParams(l, "{layers: [a, b], free_list: [x, x]}", PluginContext{}));
  EXPECT_EQ(l.free_list, (std::vector<std::string>{"x", "x"}));
  EXPECT_TRUE(declaredParams(l)[0].unique);
  EXPECT_FALSE(declaredParams(l)[1].unique);
}

TEST(Params, ConfigureErrorNamesTheParameter) {
  Demo d;
  try {
    setParams(d, "{mode: b, window: 20}", PluginContext{});
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("parameter 'window': must be <= 10 in mode b"),
              std::string::npos)
        << e.what();
  }
}

namespace {
// A third-party stage whose data file has a default, and whose configure fails without a
// ParamError (e.g. a library's own exception).
struct WithDefaultFile : Stage {
  std::string table = "tables/default.csv";
  bool fail = false;
  void declare(ParamDecl& d) override {
    d.add("table", table, "lookup table").existingPath();
    d.add("fail", fail, "make configure throw");
  }
  void configure(const PluginContext&) override {
    if (fail) throw std::runtime_error("library refused the table");
  }
  void process(FrameContext&) override {}
};

/// Creates WithDefaultFile's default table under `dir`; returns its path.
std::string writeDefaultTable(const test::TempDir& dir) {
  std::filesystem::create_directories(dir.str() + "/tables");
  const std::string path = dir.str() + "/tables/default.csv";
  std::ofstream(path) << "x\n";
  return path;
}
}  // namespace

// A default path is held to the same rule as a given one: it must exist, resolved against the
// config's folder, or the config is refused before any frame is read.
TEST(Params, DefaultDataPathMustExistAndIsResolved) {
  test::TempDir dir;
  PluginContext ctx;
  ctx.config_dir = dir.str();
  WithDefaultFile missing;
  try {
    setParams(missing, "{}", ctx);
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("parameter 'table': default data path '" + dir.str() +
                                         "/tables/default.csv' does not exist"),
              std::string::npos)
        << e.what();
  }
  const std::string table = writeDefaultTable(dir);
  WithDefaultFile present;
  setParams(present, "{}", ctx);
  EXPECT_EQ(present.table, table);
}

// Whatever configure throws is reported with the stage, not lost or left to terminate().
TEST(Params, ConfigureErrorOfAnyTypeIsReported) {
  test::TempDir dir;
  writeDefaultTable(dir);
  PluginContext ctx;
  ctx.config_dir = dir.str();
  WithDefaultFile p;
  try {
    setParams(p, "{fail: true}", ctx);
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("library refused the table"), std::string::npos)
        << e.what();
  }
}

TEST(Params, UnparsableYamlNamesTheText) {
  Demo d;
  try {
    setParams(d, "{cell_m: [1", PluginContext{});
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("parameters '{cell_m: [1': "), std::string::npos)
        << e.what();
  }
}

}  // namespace terramrf
