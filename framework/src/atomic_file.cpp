#include "terramrf/atomic_file.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
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
                     "." + target.filename().string() + ".tmp." + std::to_string(::getpid()) +
                     ".XXXXXX";
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

namespace {
/// `digits` as a pid, or 0 if it is not one (empty, not all digits, too long).
pid_t pidIn(const std::string& digits) {
  if (digits.empty() || digits.size() > 9) return 0;  // pid_t is at most 2^22 on Linux
  for (char c : digits)
    if (c < '0' || c > '9') return 0;
  return static_cast<pid_t>(std::stol(digits));
}

/// The writer whose pid a temporary name carries, or 0 if `name` is none of ours.
/// `is_dir`: mesh export folders (`X.tmp-<pid>`, `X.old-<pid>`); files: writeFileAtomic's
/// `.X.tmp.<pid>.XXXXXX` and `.write_probe_<pid>`. `old` is set for `X.old-<pid>`.
pid_t tempWriter(const std::string& name, bool is_dir, const std::string& export_name, bool& old) {
  old = false;
  if (is_dir) {
    // Only the named export's own folders: any folder "<x>.old-<digits>" of the user's (a
    // backup, "photos.old-2021") would otherwise be removed whole when that pid is free.
    if (export_name.empty()) return 0;
    for (const char* mark : {".tmp-", ".old-"}) {
      const std::string prefix = export_name + mark;
      if (name.size() <= prefix.size() || name.compare(0, prefix.size(), prefix) != 0) continue;
      const pid_t pid = pidIn(name.substr(prefix.size()));
      if (pid == 0) continue;
      old = mark[1] == 'o';
      return pid;
    }
    return 0;
  }
  if (name.rfind(".write_probe_", 0) == 0) return pidIn(name.substr(13));
  // .<name>.tmp.<pid>.XXXXXX: mkstemp's six characters after the pid.
  if (name.size() < 1 + 1 + 5 + 1 + 1 + 6 || name[0] != '.') return 0;
  const std::size_t dot = name.size() - 7;
  if (name[dot] != '.') return 0;
  for (std::size_t k = dot + 1; k < name.size(); ++k)
    if (!std::isalnum(static_cast<unsigned char>(name[k]))) return 0;
  const std::size_t tmp = name.rfind(".tmp.", dot);
  if (tmp == std::string::npos || tmp < 2) return 0;
  return pidIn(name.substr(tmp + 5, dot - tmp - 5));
}

/// True only when no process has this pid (ESRCH). EPERM: alive, another user's.
bool writerIsGone(pid_t pid) { return pid > 1 && ::kill(pid, 0) == -1 && errno == ESRCH; }
}  // namespace

std::vector<std::string> removeStaleTemps(const std::string& dir, int max_depth,
                                          const std::string& export_name) {
  namespace fs = std::filesystem;
  std::vector<std::string> done;
  std::error_code ec;
  // Gathered first, changed after: removing while iterating would skip entries.
  std::vector<std::pair<fs::path, bool>> stale;  // path, X.old-<pid>
  fs::recursive_directory_iterator it(dir, fs::directory_options::skip_permission_denied, ec), end;
  for (; !ec && it != end; it.increment(ec)) {
    const fs::directory_entry& e = *it;
    std::error_code ec2;
    const bool is_dir = e.is_directory(ec2) && !e.is_symlink(ec2);
    const bool is_file = e.is_regular_file(ec2) && !e.is_symlink(ec2);
    bool old = false;
    const pid_t pid = (is_dir || is_file)
                          ? tempWriter(e.path().filename().string(), is_dir, export_name, old)
                          : 0;
    if (pid != 0 && writerIsGone(pid)) {
      stale.emplace_back(e.path(), old);
      if (is_dir) it.disable_recursion_pending();  // removed whole
      continue;
    }
    if (is_dir && it.depth() >= max_depth) it.disable_recursion_pending();
  }
  for (const auto& [path, old] : stale) {
    std::error_code rec;
    if (old) {
      // X.old-<pid>: the previous export, moved aside just before the new one was moved in. With
      // X missing the writer died between the two renames, and this is the only export left.
      const std::string name = path.filename().string();
      const fs::path target = path.parent_path() / name.substr(0, name.rfind(".old-"));
      if (!fs::exists(target, rec)) {
        fs::rename(path, target, rec);
        done.push_back(rec ? "cannot restore " + target.string() + " from " + path.string() +
                                 " (left by a process that no longer runs): " + rec.message()
                           : "restored " + target.string() + " from " + path.string() +
                                 " (moved aside by a process that no longer runs)");
        continue;
      }
    }
    fs::remove_all(path, rec);
    done.push_back(rec ? "cannot remove " + path.string() +
                             " (left by a process that no longer runs): " + rec.message()
                       : "removed " + path.string() + " (left by a process that no longer runs)");
  }
  return done;
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
