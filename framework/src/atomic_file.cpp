#include "terramrf/atomic_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "terramrf/errors.hpp"

namespace terramrf {

void writeFileAtomic(const std::string& path, std::string_view bytes) {
  namespace fs = std::filesystem;
  const fs::path target(path);
  std::error_code ec;
  if (target.has_parent_path()) {
    fs::create_directories(target.parent_path(), ec);
    if (ec) {
      throw std::runtime_error("cannot create folder '" + target.parent_path().string() +
                               "' for output '" + path + "': " + ec.message());
    }
  }
  std::string tmpl = (target.has_parent_path() ? target.parent_path() / "" : fs::path()).string() +
                     "." + target.filename().string() + ".tmp.XXXXXX";
  const int fd = ::mkstemp(tmpl.data());
  if (fd < 0) {
    throw std::runtime_error("cannot write output '" + path + "': " + std::strerror(errno));
  }
  std::size_t off = 0;
  while (off < bytes.size()) {
    const ssize_t w = ::write(fd, bytes.data() + off, bytes.size() - off);
    if (w < 0) {
      if (errno == EINTR) continue;
      const std::string why = std::strerror(errno);
      ::close(fd);
      ::unlink(tmpl.c_str());
      throw std::runtime_error("cannot write output '" + path + "': " + why);
    }
    off += static_cast<std::size_t>(w);
  }
  ::fchmod(fd, 0644);
  // A write error can surface only at fsync or close (a full disk, NFS); renaming then would
  // replace a good file with a short one.
  const bool synced = ::fsync(fd) == 0 || errno == EINVAL;  // EINVAL: a file that cannot sync
  const std::string sync_why = synced ? "" : std::strerror(errno);
  const bool closed = ::close(fd) == 0;
  if (!synced || !closed) {
    const std::string why = !synced ? sync_why : std::strerror(errno);
    ::unlink(tmpl.c_str());
    throw std::runtime_error("cannot write output '" + path + "': " + why);
  }
  if (::rename(tmpl.c_str(), path.c_str()) != 0) {
    const std::string why = std::strerror(errno);
    ::unlink(tmpl.c_str());
    throw std::runtime_error("cannot replace output '" + path + "': " + why);
  }
}

std::string safeFileName(std::string s) {
  for (char& ch : s) {
    if (ch == '/' || ch == '\\' || ch == ':' || ch == ' ') ch = '_';
  }
  if (s.empty() || s == "." || s == "..") s = "_" + s;
  return s;
}

std::vector<std::string> frameFileNames(const std::string& dir, const std::string& stem,
                                        const std::vector<std::string>& cameras,
                                        const std::string& ext) {
  namespace fs = std::filesystem;
  std::vector<std::string> out = {(fs::path(dir) / (stem + ext)).string()};
  for (const std::string& camera : cameras) {
    std::string f = (fs::path(dir) / (stem + "_" + safeFileName(camera) + ext)).string();
    if (std::find(out.begin(), out.end(), f) == out.end()) out.push_back(std::move(f));
  }
  return out;
}

std::string readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "cannot open file for reading");
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace terramrf
