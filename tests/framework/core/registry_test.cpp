#include "terramrf/registry.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

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

namespace {
std::string loadError(const std::string& lib) {
  try {
    PluginRegistry::inspect(lib);
  } catch (const PluginLoadError& e) {
    return e.what();
  }
  return "(loaded)";
}
}  // namespace

// -mavx or -march=native raise Eigen's static alignment: Frame is 1056 bytes in such a plugin and
// 976 in the core, which the version string cannot show. Before, it loaded and read frames
// through the wrong offsets.
TEST(Registry, RejectsLibraryBuiltWithAnotherEigenAlignmentNamingTheSizes) {
  const std::string lib = kTestPlugins + "/layout_mismatch/layout_mismatch.so";
  const std::string m = loadError(lib);
  EXPECT_EQ(m.rfind(lib + ": built with other compiler flags than this TerraMRF", 0), 0u) << m;
  EXPECT_NE(m.find("Eigen static alignment 32 bytes in the plugin, " +
                   std::to_string(EIGEN_MAX_STATIC_ALIGN_BYTES) + " in the core"),
            std::string::npos)
      << m;
  // Frame holds an optional Eigen::Isometry3d: its size changes with the alignment.
  const std::size_t frame = m.find("; Frame ");
  ASSERT_NE(frame, std::string::npos) << m;
  EXPECT_NE(m.find(" bytes aligned to 32 in the plugin, " + std::to_string(sizeof(Frame)) +
                       " aligned to " + std::to_string(alignof(Frame)) + " in the core",
                   frame),
            std::string::npos)
      << m;
  EXPECT_NE(m.find("build the plugin with the same compiler flags as TerraMRF"), std::string::npos)
      << m;
}

// Each damaged descriptor is refused naming the file; before, a null descriptor, type or create
// crashed the loader, and an empty type loaded.
TEST(Registry, RejectsDamagedDescriptorsNamingTheFile) {
  const std::string dir = kTestPlugins + "/bad_descriptors";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"null_descriptor", "terramrf_plugin_descriptor() returned no descriptor (null)"},
      {"null_type", "descriptor has no type name (null or empty)"},
      {"empty_type", "descriptor has no type name (null or empty)"},
      {"null_summary", "descriptor of 'test_bad_null_summary' has no summary (null)"},
      {"null_create", "descriptor of 'test_bad_null_create' has no create function (null)"},
      {"bad_kind", "descriptor kind 9 is not a plugin kind (expected 0 to 5"},
  };
  for (const auto& [defect, why] : cases) {
    const std::string lib = dir + "/" + defect + ".so";
    EXPECT_EQ(loadError(lib).rfind(lib + ": " + why, 0), 0u) << loadError(lib);
  }
  // A scan lists them as problems and goes on with the libraries that do load.
  PluginRegistry reg({dir});
  EXPECT_EQ(reg.problems().size(), cases.size());
  EXPECT_NE(reg.find("test_bad_create_returns_null"), nullptr);
  EXPECT_NE(reg.find("test_bad_wrong_kind"), nullptr);
}

// Found at create(): an object that is not there, or not of the kind the descriptor says (an
// output declared a source), which every caller would static_cast to the kind's base class.
TEST(Registry, CreateRefusesANullObjectAndOneNotOfItsDeclaredKind) {
  const std::string dir = kTestPlugins + "/bad_descriptors";
  PluginRegistry reg({dir});
  try {
    reg.create("test_bad_create_returns_null");
    ADD_FAILURE() << "no error";
  } catch (const PluginLoadError& e) {
    EXPECT_EQ(std::string(e.what()),
              dir +
                  "/create_returns_null.so: creating a 'test_bad_create_returns_null' returned "
                  "no object (null)");
  }
  try {
    reg.create("test_bad_wrong_kind");
    ADD_FAILURE() << "no error";
  } catch (const PluginLoadError& e) {
    EXPECT_EQ(std::string(e.what()),
              dir +
                  "/wrong_kind.so: 'test_bad_wrong_kind' is declared a source plugin, but its "
                  "class does not derive from terramrf::Source; fix the kind in its "
                  "TERRAMRF_PLUGIN(...) line");
  }
}

// A static initialiser that throws ends the process inside dlopen, where nothing can catch it;
// before, the process ended (exit 134) without saying which of the libraries it was.
TEST(RegistryDeathTest, AStaticInitialiserThatThrowsIsNamedBeforeTheProcessEnds) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  const std::string lib = kTestPlugins + "/throwing_init/throwing_init.so";
  EXPECT_DEATH(PluginRegistry::inspect(lib),
               "terramrf: ended while loading plugin library " + lib +
                   ": its static initialisation threw: no licence file \\(test\\)");
}

TEST(Registry, DebugVariableNamesEachLibraryBeforeItIsOpened) {
  const std::string lib = kTestPlugins + "/synthetic_source/synthetic_source.so";
  test::ScopedEnv debug("TERRAMRF_PLUGIN_DEBUG", "1");
  testing::internal::CaptureStderr();
  PluginRegistry::inspect(lib);
  EXPECT_EQ(testing::internal::GetCapturedStderr(),
            "terramrf: loading plugin library " + lib + "\n");
}

// A folder of the search path that is not there was skipped without a word: a typo in
// TERRAMRF_PLUGIN_PATH then showed only as "unknown plugin type".
TEST(Registry, AMissingPluginFolderIsAProblemNamingIt) {
  test::TempDir tmp;
  const std::string missing = tmp.str() + "/no_such_folder";
  std::ofstream(tmp.str() + "/a_file") << "x";
  PluginRegistry reg({missing, tmp.str() + "/a_file", kTestPlugins + "/synthetic_source"});
  ASSERT_EQ(reg.problems().size(), 2u);
  EXPECT_EQ(reg.problems()[0], missing + ": plugin folder does not exist (skipped)");
  EXPECT_EQ(reg.problems()[1], tmp.str() + "/a_file: plugin folder is not a folder (skipped)");
  EXPECT_NE(reg.find("test_synthetic"), nullptr);
}

}  // namespace terramrf
