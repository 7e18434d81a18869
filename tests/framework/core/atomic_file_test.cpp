#include "terramrf/atomic_file.hpp"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <thread>

#include "terramrf/errors.hpp"
#include "terramrf/text_format.hpp"
#include "test_support.hpp"

namespace terramrf {

TEST(AtomicFile, WritesAndReplaces) {
  test::TempDir d;
  const std::string p = d.str() + "/sub/dir/x.txt";
  writeFileAtomic(p, "first");
  EXPECT_EQ(readFile(p), "first");
  writeFileAtomic(p, "second");
  EXPECT_EQ(readFile(p), "second");
  // No temp files left behind.
  int n = 0;
  for (auto& e : std::filesystem::directory_iterator(d.str() + "/sub/dir")) ++n, (void)e;
  EXPECT_EQ(n, 1);
}

TEST(AtomicFile, FailureNamesPathAndKeepsOldFile) {
  if (::geteuid() == 0) {
    // Root ignores permissions; use a path whose parent is a file instead.
    test::TempDir d;
    writeFileAtomic(d.str() + "/file", "x");
    try {
      writeFileAtomic(d.str() + "/file/child.txt", "y");
      FAIL();
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(d.str() + "/file"), std::string::npos) << e.what();
    }
    EXPECT_EQ(readFile(d.str() + "/file"), "x");
    return;
  }
  test::TempDir d;
  const std::string p = d.str() + "/good.txt";
  writeFileAtomic(p, "good");
  ::chmod(d.str().c_str(), 0555);
  EXPECT_THROW(writeFileAtomic(p, "bad"), std::runtime_error);
  ::chmod(d.str().c_str(), 0755);
  EXPECT_EQ(readFile(p), "good");
}

// A folder where the output should go cannot be replaced by a file: the error names the output
// and the folder, with its contents, and no temporary file is left beside it.
TEST(AtomicFile, AFolderInTheWayIsNamedAndLeftAsItWas) {
  test::TempDir d;
  const std::string p = d.str() + "/summary.json";
  writeFileAtomic(p + "/kept.txt", "kept");
  try {
    writeFileAtomic(p, "{}");
    FAIL() << "replaced a folder";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()).rfind("cannot replace output '" + p + "': ", 0), 0u)
        << e.what();
  }
  EXPECT_EQ(readFile(p + "/kept.txt"), "kept");
  int n = 0;
  for (auto& e : std::filesystem::directory_iterator(d.str())) ++n, (void)e;
  EXPECT_EQ(n, 1);  // the folder alone: the temporary file was removed
}

int entries(const std::string& dir) {
  int n = 0;
  for (auto& e : std::filesystem::directory_iterator(dir)) ++n, (void)e;
  return n;
}

// Small pieces gathered, large ones written through, in order; the target appears only at commit.
TEST(AtomicFileWriter, StreamsPiecesOfAnySizeAndReplacesOnlyAtCommit) {
  test::TempDir d;
  const std::string p = d.str() + "/mesh.obj";
  writeFileAtomic(p, "old");
  std::string expected;
  {
    AtomicFileWriter w(p);
    for (int i = 0; i < 5000; ++i) {
      const std::string line = "v " + std::to_string(i) + "\n";
      w.stream() << line;
      expected += line;
      if (i % 1000 == 0) {
        const std::string big(200 * 1024, char('a' + i / 1000));  // past the gathering size
        w.stream().write(big.data(), std::streamsize(big.size()));
        expected += big;
      }
    }
    EXPECT_EQ(w.bytes(), expected.size());
    EXPECT_EQ(static_cast<std::uint64_t>(w.stream().tellp()), expected.size());
    EXPECT_EQ(readFile(p), "old");  // not yet
    w.commit();
  }
  EXPECT_EQ(readFile(p), expected);
  EXPECT_EQ(entries(d.str()), 1);
}

TEST(AtomicFileWriter, WithoutCommitNothingIsReplacedAndNoTemporaryStays) {
  test::TempDir d;
  const std::string p = d.str() + "/mesh.ply";
  writeFileAtomic(p, "good");
  try {
    AtomicFileWriter w(p);
    w.stream() << std::string(3 << 20, 'x');
    throw std::runtime_error("encoder failed");
  } catch (const std::runtime_error&) {
  }
  EXPECT_EQ(readFile(p), "good");
  EXPECT_EQ(entries(d.str()), 1);
  AtomicFileWriter w(p);
  w.stream() << "too large";
  w.discard();
  EXPECT_EQ(readFile(p), "good");
  EXPECT_EQ(entries(d.str()), 1);
  EXPECT_THROW(w.commit(), std::runtime_error);

  // A stream the writer put into a bad state (a negative count) is not committed either.
  AtomicFileWriter bad(p);
  bad.stream() << "partial";
  bad.stream().write("x", -1);
  try {
    bad.commit();
    FAIL() << "committed a stream in a bad state";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()),
              "cannot write output '" + p + "': a write to its stream failed");
  }
  EXPECT_EQ(readFile(p), "good");
  EXPECT_EQ(entries(d.str()), 1);
}

// A disk that fills up while streaming (RLIMIT_FSIZE stands in for it: writes past the limit fail
// with EFBIG): commit() names the file and the reason, the old file stays, no temporary is left.
TEST(AtomicFileWriter, AFullDiskIsReportedAtCommitNamingTheFile) {
  test::TempDir d;
  const std::string p = d.str() + "/terrain.obj";
  writeFileAtomic(p, "previous");
  struct rlimit old {};
  ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &old), 0);
  auto* old_handler = std::signal(SIGXFSZ, SIG_IGN);  // else the process is killed at the limit
  std::string what;
  {
    AtomicFileWriter w(p);
    struct rlimit lim = old;
    lim.rlim_cur = 100000;
    ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &lim), 0);
    for (int i = 0; i < 100000; ++i) w.stream() << "f 1/1 2/2 3/3\n";
    try {
      w.commit();
    } catch (const std::runtime_error& e) {
      what = e.what();
    }
  }
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &old), 0);
  std::signal(SIGXFSZ, old_handler);
  EXPECT_EQ(what, "cannot write output '" + p + "': " + std::strerror(EFBIG));
  EXPECT_EQ(readFile(p), "previous");
  EXPECT_EQ(entries(d.str()), 1);
}

TEST(AtomicFile, ReadMissingFileNamesIt) {
  try {
    readFile("/no/such/file.bin");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/no/such/file.bin"), std::string::npos);
  }
}

TEST(TextFormat, JsonAndCsvQuoting) {
  EXPECT_EQ(jsonQuote("road"), "\"road\"");
  EXPECT_EQ(jsonQuote("a\"b\\c"), "\"a\\\"b\\\\c\"");
  EXPECT_EQ(jsonQuote("x\ny\tz"), "\"x\\ny\\u0009z\"");
  EXPECT_EQ(jsonQuote("Gelände"), "\"Gelände\"");  // UTF-8 passes through
  EXPECT_EQ(csvField("road"), "road");
  EXPECT_EQ(csvField("a,b"), "\"a,b\"");
  EXPECT_EQ(csvField("say \"hi\""), "\"say \"\"hi\"\"\"");
  EXPECT_EQ(csvField("two\r\nlines"), "\"two\r\nlines\"");
}

TEST(TextFormat, ByteSizesForMessages) {
  EXPECT_EQ(byteSize(0), "0 bytes");
  EXPECT_EQ(byteSize(1023), "1023 bytes");
  EXPECT_EQ(byteSize(1536), "1.5 KiB");
  EXPECT_EQ(byteSize(256.0 * 1024 * 1024), "256 MiB");
  EXPECT_EQ(byteSize(1000.0 * 1024), "0.977 MiB");  // never "1e+03 KiB"
  EXPECT_EQ(byteSize(128000.0 * 128000 * 3), "45.8 GiB");
  EXPECT_EQ(byteSize(1e30), "8.67e+11 EiB");  // beyond the units: still a number
}

TEST(SafeFileName, KeepsANameInsideItsFolder) {
  EXPECT_EQ(safeFileName("000042"), "000042");
  EXPECT_EQ(safeFileName("../etc/passwd"), ".._etc_passwd");
  EXPECT_EQ(safeFileName("cam 2:left\\x"), "cam_2_left_x");
  EXPECT_EQ(safeFileName(""), "_");
  EXPECT_EQ(safeFileName("."), "_.");
  EXPECT_EQ(safeFileName(".."), "_..");
}

namespace {
namespace fs = std::filesystem;
using test::deadPid;
void touch(const fs::path& p, const std::string& text = "x") { std::ofstream(p) << text; }
}  // namespace

// A writer killed mid-write (SIGKILL, or before session 38 any SIGTERM) leaves its temporary
// file; its name now carries the writer's pid, so once the writer is gone it is known stale and
// removed, and no other file is touched. Before, it was `.big.bin.tmp.XXXXXX` and stayed.
TEST(AtomicFile, ATemporaryLeftByAKilledWriterNamesItAndIsRemoved) {
  test::TempDir d;
  const std::string big(16 << 20, 'x');
  writeFileAtomic(d.str() + "/big.bin", "previous");  // replaced whole or not at all
  std::string left;
  for (int attempt = 0; attempt < 50 && left.empty(); ++attempt) {
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      for (;;) writeFileAtomic(d.str() + "/big.bin", big);
    }
    // Killed while a temporary is there (most of each write is spent on it).
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(5);
    while (std::chrono::steady_clock::now() < until) {
      bool seen = false;
      for (const auto& e : fs::directory_iterator(d.str()))
        seen = seen || e.path().filename().string().rfind(".big.bin.tmp.", 0) == 0;
      if (seen) break;
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
    ::kill(child, SIGKILL);
    int status = 0;
    ::waitpid(child, &status, 0);
    for (const auto& e : fs::directory_iterator(d.str()))
      if (e.path().filename().string().rfind(".big.bin.tmp.", 0) == 0) {
        left = e.path().filename().string();
        EXPECT_EQ(left.rfind(".big.bin.tmp." + std::to_string(child) + ".", 0), 0u) << left;
      }
  }
  ASSERT_FALSE(left.empty()) << "no write was caught mid-way";
  const std::vector<std::string> done = removeStaleTemps(d.str());
  ASSERT_EQ(done.size(), 1u);
  EXPECT_EQ(done[0],
            "removed " + d.str() + "/" + left + " (left by a process that no longer runs)");
  EXPECT_FALSE(fs::exists(d.str() + "/" + left));
  EXPECT_TRUE(fs::exists(d.str() + "/big.bin"));
}

// What removeStaleTemps touches: our temporaries whose writer is gone, and nothing else (a live
// writer's, names without a pid, names of other shapes, folders deeper than asked, folders not
// named after the export, which used to go if their digits named no process); a mesh
// export moved aside by a killed swap is put back where the export is missing.
TEST(AtomicFile, OnlyOurTemporariesOfWritersThatAreGoneAreRemoved) {
  test::TempDir d;
  const fs::path root = d.str();
  const std::string dead = std::to_string(deadPid()), live = std::to_string(::getpid());
  fs::create_directories(root / "grid");
  fs::create_directories(root / "a/b/c/d/e");
  const std::vector<fs::path> removed = {
      root / ("grid/.000041.png.tmp." + dead + ".hbVTdD"),
      root / (".timing.md.tmp." + dead + ".A1b2C3"),
      root / (".write_probe_" + dead),
      root / ("a/b/.x.csv.tmp." + dead + ".zzzzzz"),
  };
  const std::vector<fs::path> kept = {
      root / ("grid/.000042.png.tmp." + live + ".hbVTdD"),  // a live writer's
      root / "grid/.000043.png.tmp.hbVTdD",                 // no pid (before session 38)
      root / ("grid/000044.png.tmp." + dead + ".hbVTdD"),   // no leading dot: not ours
      root / ("grid/.000045.png.tmp." + dead + ".hbVTd"),   // not mkstemp's six characters
      root / ("grid/.000046.png.tmp.1" + dead + "x.hbVTdD"),
      root / ("notes.tmp-" + dead),                        // a file, not an export folder
      root / ("a/b/c/d/e/.deep.tmp." + dead + ".qwerty"),  // deeper than max_depth
      root / "grid/.1.tmp.1.abcdef",                       // pid 1 is never taken for gone
  };
  for (const auto& p : removed) touch(p);
  for (const auto& p : kept) touch(p);
  // A killed mesh export: its half-written folder, and the previous export moved aside with the
  // export itself missing (killed between the two renames of the swap).
  fs::create_directories(root / ("mesh.tmp-" + dead + "/textures"));
  fs::create_directories(root / ("mesh.old-" + dead));
  touch(root / ("mesh.old-" + dead) / "terrain.obj", "previous");
  // Another export's aside copy where the export is there: removed.
  fs::create_directories(root / "mesh2");
  fs::create_directories(root / ("mesh2.old-" + dead));
  fs::create_directories(root / ("mesh3.tmp-" + live));  // an export in progress
  // Folders of other names are the user's, whatever they look like (a backup named by year).
  fs::create_directories(root / ("photos.old-" + dead));
  fs::create_directories(root / ("photos.tmp-" + dead));
  // Files are gathered by their exact shape anywhere; folders only by the export's name (mesh
  // and mesh2 here: two calls, as exportMesh makes one per export).
  std::vector<std::string> done = removeStaleTemps(d.str(), 3, "mesh");
  for (const auto& line : removeStaleTemps(d.str(), 0, "mesh2")) done.push_back(line);
  EXPECT_TRUE(fs::exists(root / ("photos.old-" + dead)));
  EXPECT_TRUE(fs::exists(root / ("photos.tmp-" + dead)));
  for (const auto& p : removed) EXPECT_FALSE(fs::exists(p)) << p;
  for (const auto& p : kept) EXPECT_TRUE(fs::exists(p)) << p;
  EXPECT_FALSE(fs::exists(root / ("mesh.tmp-" + dead)));
  EXPECT_FALSE(fs::exists(root / ("mesh.old-" + dead)));
  EXPECT_EQ(readFile((root / "mesh/terrain.obj").string()), "previous");
  EXPECT_TRUE(fs::exists(root / "mesh2"));
  EXPECT_FALSE(fs::exists(root / ("mesh2.old-" + dead)));
  EXPECT_TRUE(fs::exists(root / ("mesh3.tmp-" + live)));
  EXPECT_EQ(done.size(), removed.size() + 3) << ::testing::PrintToString(done);
  EXPECT_NE(std::find(done.begin(), done.end(),
                      "restored " + (root / "mesh").string() + " from " +
                          (root / ("mesh.old-" + dead)).string() +
                          " (moved aside by a process that no longer runs)"),
            done.end())
      << ::testing::PrintToString(done);
  EXPECT_TRUE(removeStaleTemps(d.str() + "/missing").empty());  // no folder: nothing, no throw
}

}  // namespace terramrf
