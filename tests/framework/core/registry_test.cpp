#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "terramrf/registry.hpp"
#include "test_support.hpp"

namespace terramrf {

static const std::string kTestPlugins = TERRAMRF_TEST_PLUGIN_DIR;

TEST(Registry, FindsBuiltInPlugins) {
  PluginRegistry reg({test::pluginDir()});
  for (const char* t : {"eigen_preclass", "height_difference", "potts_gaussian", "icm"}) {
    ASSERT_NE(reg.find(t), nullptr) << t;
  }
  EXPECT_EQ(reg.find("icm")->kind, PluginKind::kOptimiser);
  auto p = reg.create("height_difference");
  EXPECT_EQ(p->type(), "height_difference");
  EXPECT_THROW(reg.create("no_such_plugin"), PluginLoadError);
}

TEST(Registry, RejectsLibraryBuiltAgainstAnotherVersion) {
  const std::string lib = kTestPlugins + "/wrong_abi/wrong_abi.so";
  try {
    PluginRegistry::inspect(lib);
    FAIL();
  } catch (const PluginLoadError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find(lib), std::string::npos) << m;
    EXPECT_NE(m.find("built against 'terramrf 0.0.1"), std::string::npos) << m;
  }
  PluginRegistry reg({kTestPlugins + "/wrong_abi"});
  EXPECT_TRUE(reg.list().empty());
  ASSERT_EQ(reg.problems().size(), 1u);
}

TEST(Registry, RejectsLibraryThatIsNotAPlugin) {
  const std::string lib = kTestPlugins + "/not_a_plugin/not_a_plugin.so";
  try {
    PluginRegistry::inspect(lib);
    FAIL();
  } catch (const PluginLoadError& e) {
    EXPECT_NE(std::string(e.what()).find("not a TerraMRF plugin"), std::string::npos) << e.what();
  }
}

TEST(Registry, RejectsFileThatIsNotALibrary) {
  test::TempDir tmp;
  const std::string f = tmp.str() + "/terramrf_fake.so";
  std::ofstream(f) << "this is text";
  try {
    PluginRegistry::inspect(f);
    FAIL();
  } catch (const PluginLoadError& e) {
    EXPECT_NE(std::string(e.what()).find("not a loadable shared library"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find(f), std::string::npos);
  }
}

TEST(Registry, EnvironmentVariableAddsFolders) {
  std::vector<std::string> dirs;
  {
    test::ScopedEnv path("TERRAMRF_PLUGIN_PATH", (kTestPlugins + "/synthetic_source").c_str());
    dirs = PluginRegistry::defaultSearchDirs();
  }
  PluginRegistry reg(dirs);
  EXPECT_NE(reg.find("test_synthetic"), nullptr);
}

}  // namespace terramrf
