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

namespace {

/// write(2) of all `n` bytes; false with errno set on failure.
bool writeAll(int fd, const char* data, std::size_t n) {
  while (n > 0) {
    const ssize_t w = ::write(fd, data, n);
    if (w < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    data += w;
    n -= static_cast<std::size_t>(w);
  }
  return true;
}

}  // namespace

/// A stream buffer over the temporary file's descriptor: large writes go straight to the file,
/// small ones are gathered. After a failed write it takes nothing more and keeps the reason.
class AtomicFileWriter::Buffer : public std::streambuf {
 public:
  explicit Buffer(int fd) : fd_(fd) {}
  int fd() const { return fd_; }
  const std::string& error() const { return error_; }
  /// Bytes taken so far, written or buffered (a failed write does not take them back).
  std::uint64_t bytes() const { return taken_ + static_cast<std::uint64_t>(pptr() - pbase()); }
  bool flush() { return sync() == 0; }
  void release() { fd_ = -1; }
  /// `n` bytes written through, after what is buffered: no copy of a whole file in one string.
  bool writeThrough(const char* s, std::size_t n) {
    if (!flush()) return false;
    taken_ += n;
    return put(s, n);
  }

 protected:
  // tellp(): the bytes taken so far (the file is only ever appended to).
  pos_type seekoff(off_type off, std::ios_base::seekdir dir, std::ios_base::openmode) override {
    if (off != 0 || dir != std::ios_base::cur) return pos_type(off_type(-1));
    return pos_type(static_cast<off_type>(bytes()));
  }
  int_type overflow(int_type c) override {
    if (!flush()) return traits_type::eof();
    if (traits_type::eq_int_type(c, traits_type::eof())) return traits_type::not_eof(c);
    gather();
    *pptr() = traits_type::to_char_type(c);
    pbump(1);
    return c;
  }
  std::streamsize xsputn(const char* s, std::streamsize n) override {
    if (n <= 0 || !error_.empty()) return 0;
    if (n <= epptr() - pptr()) {
      std::copy(s, s + n, pptr());
      pbump(static_cast<int>(n));
      return n;
    }
    if (static_cast<std::size_t>(n) >= kDirect)
      return writeThrough(s, static_cast<std::size_t>(n)) ? n : 0;
    if (!flush()) return 0;
    gather();
    std::copy(s, s + n, pptr());
    pbump(static_cast<int>(n));
    return n;
  }
  int sync() override {
    const std::size_t n = static_cast<std::size_t>(pptr() - pbase());
    if (n == 0) return error_.empty() ? 0 : -1;
    taken_ += n;
    const bool ok = put(pbase(), n);
    setp(pbase(), epptr());
    return ok ? 0 : -1;
  }

 private:
  // Writes this large go to the file as they come: a whole file in one string (writeFileAtomic)
  // is not copied. Smaller ones are gathered in a buffer made on first need.
  static constexpr std::size_t kDirect = 64 << 10, kBytes = 1 << 20;
  void gather() {
    if (buf_) return;
    buf_.reset(new char[kBytes]);
    setp(buf_.get(), buf_.get() + kBytes);
  }
  bool put(const char* s, std::size_t n) {
    if (!error_.empty()) return false;
    if (!writeAll(fd_, s, n)) {
      error_ = std::strerror(errno);
      return false;
    }
    return true;
  }
  int fd_;
  std::unique_ptr<char[]> buf_;
  std::uint64_t taken_ = 0;
  std::string error_;
};

AtomicFileWriter::AtomicFileWriter(std::string path) : path_(std::move(path)) {
  namespace fs = std::filesystem;
  const fs::path target(path_);
  std::error_code ec;
  if (target.has_parent_path()) {
    fs::create_directories(target.parent_path(), ec);
    if (ec) {
      throw std::runtime_error("cannot create folder '" + target.parent_path().string() +
                               "' for output '" + path_ + "': " + ec.message());
    }
  }
  temp_ = (target.has_parent_path() ? target.parent_path() / "" : fs::path()).string() + "." +
          target.filename().string() + ".tmp." + std::to_string(::getpid()) + ".XXXXXX";
  const int fd = ::mkstemp(temp_.data());
  if (fd < 0) {
    throw std::runtime_error("cannot write output '" + path_ + "': " + std::strerror(errno));
  }
  try {
    buffer_ = std::make_unique<Buffer>(fd);
    stream_ = std::make_unique<std::ostream>(buffer_.get());
  } catch (...) {
    ::close(fd);
    ::unlink(temp_.c_str());
    throw;
  }
}

AtomicFileWriter::~AtomicFileWriter() { discard(); }

std::ostream& AtomicFileWriter::stream() { return *stream_; }

std::uint64_t AtomicFileWriter::bytes() const { return buffer_ ? buffer_->bytes() : 0; }

void AtomicFileWriter::discard() {
  if (!buffer_ || buffer_->fd() < 0) return;
  ::close(buffer_->fd());
  buffer_->release();
  ::unlink(temp_.c_str());
}

void AtomicFileWriter::checkWritten() {
  if (!buffer_ || buffer_->fd() < 0)
    throw std::runtime_error("cannot write output '" + path_ + "': already committed or discarded");
  if (!buffer_->flush() || stream_->bad()) {
    // bad() without an OS error: a writer gave the stream something it could not take.
    const std::string why =
        buffer_->error().empty() ? "a write to its stream failed" : buffer_->error();
    discard();
    throw std::runtime_error("cannot write output '" + path_ + "': " + why);
  }
}

void AtomicFileWriter::commit() {
  checkWritten();
  const int fd = buffer_->fd();
  ::fchmod(fd, 0644);
  // A write error can surface only at fsync or close (a full disk, NFS); renaming then would
  // replace a good file with a short one.
  const bool synced = ::fsync(fd) == 0 || errno == EINVAL;  // EINVAL: a file that cannot sync
  const std::string sync_why = synced ? "" : std::strerror(errno);
  const bool closed = ::close(fd) == 0;
  const std::string close_why = closed ? "" : std::strerror(errno);
  buffer_->release();
  if (!synced || !closed) {
    ::unlink(temp_.c_str());
    throw std::runtime_error("cannot write output '" + path_ +
                             "': " + (!synced ? sync_why : close_why));
  }
  if (::rename(temp_.c_str(), path_.c_str()) != 0) {
    const std::string why = std::strerror(errno);
    ::unlink(temp_.c_str());
    throw std::runtime_error("cannot replace output '" + path_ + "': " + why);
  }
}

void AtomicFileWriter::write(std::string_view bytes) {
  if (buffer_ && buffer_->fd() >= 0) buffer_->writeThrough(bytes.data(), bytes.size());
}

void writeFileAtomic(const std::string& path, std::string_view bytes) {
  AtomicFileWriter w(path);
  w.write(bytes);
  w.commit();
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
