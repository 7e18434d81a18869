#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>

#include "terramrf/atomic_file.hpp"
#include "terramrf/text_format.hpp"
#include "terramrf/errors.hpp"
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

}  // namespace terramrf
