#pragma once
// Internal to the dataset readers: filesystem tests that answer "no" instead of throwing on a
// path that cannot be examined (permissions, dangling links), so a reader can word its own error.
#include <filesystem>
#include <system_error>

namespace terramrf::io_detail {

inline bool isDir(const std::filesystem::path& p) {
  std::error_code ec;
  return std::filesystem::is_directory(p, ec);
}

inline bool isFile(const std::filesystem::path& p) {
  std::error_code ec;
  return std::filesystem::is_regular_file(p, ec);
}

}  // namespace terramrf::io_detail
