#pragma once
// Outputs are written to a temporary file in the target folder and renamed over the target, so a
// crash or a failing frame never leaves a truncated file or replaces a good one.
#include <cstdint>
#include <memory>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

namespace terramrf {

/// Writes `bytes` to `path` atomically (temp file + fsync + rename). Creates parent folders.
/// Throws std::runtime_error naming the path on failure; the old file, if any, is untouched.
/// The temporary file, `.<name>.tmp.<pid>.XXXXXX` beside `path`, names its writer's process, so
/// one left by a writer that was killed can be told from one being written (removeStaleTemps).
void writeFileAtomic(const std::string& path, std::string_view bytes);

/// Streams a file to `path` atomically, for outputs too large to hold in memory first: bytes go
/// through stream() to the temporary file writeFileAtomic would use, and commit() syncs it and
/// renames it over `path`. Without commit() (a throw while writing) the temporary file is removed
/// in the destructor and `path` is untouched. Write errors (a full disk) are reported by commit(),
/// with writeFileAtomic's messages naming the path; the stream stops taking bytes after one.
class AtomicFileWriter {
 public:
  /// Creates parent folders and the temporary file; throws std::runtime_error naming `path`.
  explicit AtomicFileWriter(std::string path);
  ~AtomicFileWriter();
  AtomicFileWriter(const AtomicFileWriter&) = delete;
  AtomicFileWriter& operator=(const AtomicFileWriter&) = delete;

  std::ostream& stream();
  /// `bytes` written straight to the file after what stream() holds (no buffer made: a whole
  /// file in one string); a failure is reported by commit() as the stream's are.
  void write(std::string_view bytes);
  /// Bytes taken by stream() so far (buffered ones included).
  std::uint64_t bytes() const;
  /// Flushes, and throws std::runtime_error naming the path if a write failed (the temporary
  /// file is then removed): so an encoder that reports only "failed" can be told from a full disk.
  void checkWritten();
  /// checkWritten(), then syncs and renames; throws std::runtime_error naming the path on any
  /// failure (the temporary file is then removed). Once only.
  void commit();
  /// Removes the temporary file now (a result found wrong after writing); `path` is untouched.
  void discard();

 private:
  class Buffer;
  std::string path_, temp_;
  std::unique_ptr<Buffer> buffer_;
  std::unique_ptr<std::ostream> stream_;
};

/// Removes, in `dir` and its folders at most `max_depth` levels down (symbolic links not
/// followed), what
/// writers killed mid-write left: writeFileAtomic's `.<name>.tmp.<pid>.XXXXXX` files, the mesh
/// export's `.write_probe_<pid>` files and, when `export_name` is given, that export's
/// `<export_name>.tmp-<pid>` folders and its `<export_name>.old-<pid>` folders, which are moved
/// back to `<export_name>` when that is missing (the previous export, moved
/// aside when its writer was killed mid-swap). Only names of these exact shapes whose pid names
/// no live process (kill(pid, 0) fails with ESRCH) are touched: a live writer's, and temporary
/// files without a pid (before session 38), are left alone. Never throws; returns one line per
/// entry removed or restored, or that could not be, for the log.
std::vector<std::string> removeStaleTemps(const std::string& dir, int max_depth = 4,
                                          const std::string& export_name = "");

/// A frame id or camera name made safe as one file-name component inside an output folder: path
/// separators, ':' and spaces become '_', and "", "." and ".." get a leading '_'.
std::string safeFileName(std::string s);

/// The files an output names for one frame in folder `dir`: `<stem><ext>` and, for each of
/// `cameras` (made safe, each once), `<stem>_<camera><ext>` (`Output::frameFiles`). Exact names,
/// never a pattern: frame "a"'s files must not take in those of frame "a_b". Whether they exist is
/// not checked.
std::vector<std::string> frameFileNames(const std::string& dir, const std::string& stem,
                                        const std::vector<std::string>& cameras,
                                        const std::string& ext);

/// Reads a whole file; throws InputError naming it if it cannot be read.
std::string readFile(const std::string& path);

}  // namespace terramrf
