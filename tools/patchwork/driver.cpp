// SPDX-License-Identifier: GPL-3.0-or-later
// terramrf_patchwork_compare: Patchwork++ on the reference scans, scored by TerraMRF's own rules,
// so docs/benchmarks.md's comparison can be run again (tools/patchwork/README.md).
//
//   terramrf_patchwork_compare [--calls N] [--csv FILE] SWEEP.yaml:DATASET:FRAME ...
//
// Each scan is read by the source a sweep configures for DATASET (same points, no-return
// dropping, label map and recentring as `terramrf compare` sees them) and binned on that sweep's
// grid. Patchwork++ (default KITTI Params, one fresh instance per scan) is called twice on it and
// both calls are scored; the second is the figure to quote, since its thresholds start at zero and
// adapt from call to call. A cell is predicted obstacle if any of its points is non-ground; its
// truth, and which cells are scored, are the framework's (Evaluator, cellTruth). Then
// estimateGround is timed on one reused instance: N calls (default 30), the first dropped; for a
// KITTI `.bin` scan also reading the file and estimateGround together, to compare with TerraMRF's
// file-to-labels time.
#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <streambuf>
#include <string>
#include <vector>

#include "patchwork/patchworkpp.h"
#include "terramrf/atomic_file.hpp"
#include "terramrf/errors.hpp"
#include "terramrf/evaluation.hpp"
#include "terramrf/param_values.hpp"
#include "terramrf/registry.hpp"
#include "terramrf/terrain_grid.hpp"

#ifndef PATCHWORK_ORIGIN
#define PATCHWORK_ORIGIN "unknown"
#endif

namespace terramrf {
namespace {

namespace fs = std::filesystem;

/// One scan to compare: a dataset entry of a sweep and a frame id of its source.
struct ScanSpec {
  std::string sweep, dataset, frame;
  std::string name() const { return dataset + "/" + frame; }
};

/// Obstacle scores of one estimateGround call.
struct CallScore {
  ClassScores obstacle;
  uint64_t cells_scored = 0;
  std::size_t unassigned = 0;  ///< points in neither index list (treated as ground)
};

struct TimeStats {
  std::size_t calls = 0;  ///< counted calls (the first one is dropped)
  double median_ms = 0, min_ms = 0, max_ms = 0;
};

struct ScanResult {
  ScanSpec spec;
  std::size_t points = 0, dropped_no_return = 0;
  CallScore call[2];
  TimeStats time;
  TimeStats time_with_read;  ///< read the `.bin` + estimateGround (KITTI scans only)
};

/// Patchwork++'s constructor prints a banner on std::cout; it would land in the table.
class MuteCout {
 public:
  MuteCout() : old_(std::cout.rdbuf(&null_)) {}
  ~MuteCout() { std::cout.rdbuf(old_); }

 private:
  struct NullBuf : std::streambuf {
    int overflow(int c) override { return c; }
  } null_;
  std::streambuf* old_;
};

std::unique_ptr<patchwork::PatchWorkpp> makePatchwork() {
  MuteCout mute;
  return std::make_unique<patchwork::PatchWorkpp>(patchwork::Params());
}

ScanSpec parseScan(const std::string& arg) {
  const auto b = arg.rfind(':');
  const auto a = b == std::string::npos || b == 0 ? std::string::npos : arg.rfind(':', b - 1);
  if (a == std::string::npos || a == 0 || b == a + 1 || b + 1 == arg.size())
    throw std::invalid_argument("scan '" + arg + "': expected SWEEP.yaml:DATASET:FRAME");
  return {arg.substr(0, a), arg.substr(a + 1, b - a - 1), arg.substr(b + 1)};
}

/// The sweep's grid and its DATASET source, configured as the sweep configures it.
struct SweepSource {
  GridGeometry grid;
  std::unique_ptr<Plugin> plugin;
  Source& source() { return static_cast<Source&>(*plugin); }
};

SweepSource openSource(const ScanSpec& spec, const LabelSet& labels, PluginRegistry& registry) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(spec.sweep);
  } catch (const YAML::Exception& e) {
    throw InputError(spec.sweep, std::string("cannot read the sweep: ") + e.what());
  }
  // The scores below use the default classes; a sweep with its own would be scored differently.
  if (root["labels"])
    throw InputError(spec.sweep, "has its own 'labels'; only the default classes are supported");
  SweepSource out;
  if (const YAML::Node g = root["grid"]) {
    if (g["size_m"]) out.grid.size_m = g["size_m"].as<double>();
    if (g["cell_m"]) out.grid.cell_m = g["cell_m"].as<double>();
  }
  const YAML::Node entry = root["datasets"] ? root["datasets"][spec.dataset] : YAML::Node();
  if (!entry || !entry["type"])
    throw InputError(spec.sweep, "has no dataset '" + spec.dataset + "' with a type");
  const std::string type = entry["type"].as<std::string>();
  YAML::Emitter params;
  params << YAML::Flow << (entry["params"] ? entry["params"] : YAML::Node(YAML::NodeType::Map));

  PluginContext ctx;
  // Relative paths in the sweep (data, label map) resolve against its folder, as in `compare`.
  ctx.config_dir = fs::absolute(spec.sweep).parent_path().string();
  ctx.grid = out.grid;
  ctx.labels = &labels;
  out.plugin = registry.create(type);
  if (!dynamic_cast<Source*>(out.plugin.get()))
    throw InputError(spec.sweep, "dataset '" + spec.dataset + "': '" + type + "' is no source");
  try {
    setParams(*out.plugin, params.c_str(), ctx);
  } catch (const std::exception& e) {
    throw InputError(spec.sweep, "dataset '" + spec.dataset + "': " + e.what());
  }
  return out;
}

Frame readFrame(SweepSource& s, const ScanSpec& spec) {
  Source& src = s.source();
  std::string ids;
  for (std::size_t i = 0; i < src.size(); ++i) {
    if (src.frameId(i) == spec.frame) {
      Frame f = src.read(i);
      if (f.truth.empty()) throw InputError(f.source_path, "has no labels to score against");
      return f;
    }
    ids += (i ? ", " : "") + src.frameId(i);
  }
  throw InputError(spec.sweep, "dataset '" + spec.dataset + "' has no frame '" + spec.frame +
                                   "' (frames: " + ids + ")");
}

/// The cloud as Patchwork++ takes it: x, y, z, intensity per row (intensity feeds its reflected
/// noise removal).
Eigen::MatrixXf toPatchworkCloud(const PointCloud& pc) {
  Eigen::MatrixXf m(pc.size(), 4);
  for (std::size_t i = 0; i < pc.size(); ++i)
    m.row(i) << pc.x[i], pc.y[i], pc.z[i], pc.intensity[i];
  return m;
}

/// Scores the last estimateGround call of `pw`: the cells are labelled obstacle (any non-ground
/// point) or road, and the framework's Evaluator decides their truth and which are scored. Road
/// stands for "ground": Patchwork++ does not tell road from rough, and the obstacle scores do not
/// depend on which ground class is predicted.
CallScore scoreCall(patchwork::PatchWorkpp& pw, const Frame& frame, TerrainGrid& grid,
                    const LabelSet& labels) {
  const std::size_t n = frame.points.size();
  std::vector<uint8_t> state(n, 0);  // 0 unassigned, 1 ground, 2 non-ground
  auto mark = [&](const Eigen::VectorXi& idx, uint8_t s) {
    for (Eigen::Index k = 0; k < idx.size(); ++k) {
      const int i = idx[k];
      if (i < 0 || static_cast<std::size_t>(i) >= n)
        throw std::runtime_error("Patchwork++ returned point index " + std::to_string(i) +
                                 " for a cloud of " + std::to_string(n) + " points (" +
                                 frame.source_path + ")");
      state[i] = std::max(state[i], s);  // a point listed twice counts as non-ground
    }
  };
  mark(pw.getGroundIndices(), 1);
  mark(pw.getNongroundIndices(), 2);

  CallScore out;
  out.unassigned = static_cast<std::size_t>(std::count(state.begin(), state.end(), 0));
  std::vector<LabelId>& cell_labels = grid.labels();
  std::fill(cell_labels.begin(), cell_labels.end(), labels::kUnknown);
  for (int c = 0; c < static_cast<int>(grid.cells()); ++c) {
    if (grid.count(c) == 0) continue;
    const bool obstacle = std::any_of(grid.pointsBegin(c), grid.pointsEnd(c),
                                      [&](uint32_t p) { return state[p] == 2; });
    cell_labels[c] = obstacle ? labels::kObstacle : labels::kRoad;
  }
  Evaluator eval(labels);
  const EvalCounts counts = eval.addFrame(grid, frame);
  out.obstacle = counts.cell_wise.scores(static_cast<LabelId>(labels.obstacle()));
  out.cells_scored = counts.cells_scored;
  return out;
}

/// A KITTI `.bin` (float32 x, y, z, intensity per point) as an N x 4 matrix, read in one block
/// the way a caller of Patchwork++ reads it; no point is dropped.
Eigen::MatrixXf readKittiBin(const std::string& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) throw InputError(path, "cannot be opened");
  const std::streamsize bytes = in.tellg();
  if (bytes < 0 || bytes % 16) throw InputError(path, "size is not a multiple of 16 bytes");
  in.seekg(0);
  Eigen::Matrix<float, Eigen::Dynamic, 4, Eigen::RowMajor> rows(bytes / 16, 4);
  if (!in.read(reinterpret_cast<char*>(rows.data()), bytes))
    throw InputError(path, "could not be read");
  return rows;  // column-major, as estimateGround takes it
}

/// N calls on one reused instance (as a stream of scans would use it), the first dropped: it
/// allocates the zone buffers and starts from zero thresholds. With `bin`, each call reads it
/// first.
TimeStats timeCalls(const Eigen::MatrixXf& cloud, int calls, const std::string& bin = "") {
  TimeStats t;
  if (calls < 2) return t;
  auto pw = makePatchwork();
  std::vector<double> ms;
  for (int k = 0; k < calls; ++k) {
    const auto t0 = std::chrono::steady_clock::now();
    if (bin.empty()) {
      pw->estimateGround(cloud);
    } else {
      pw->estimateGround(readKittiBin(bin));
    }
    const auto t1 = std::chrono::steady_clock::now();
    if (k > 0) ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
  }
  std::sort(ms.begin(), ms.end());
  const std::size_t m = ms.size();
  t.calls = m;
  t.median_ms = m % 2 ? ms[m / 2] : 0.5 * (ms[m / 2 - 1] + ms[m / 2]);
  t.min_ms = ms.front();
  t.max_ms = ms.back();
  return t;
}

ScanResult compareScan(const ScanSpec& spec, const LabelSet& labels, PluginRegistry& registry,
                       int calls) {
  SweepSource src = openSource(spec, labels, registry);
  const Frame frame = readFrame(src, spec);
  ScanResult r;
  r.spec = spec;
  r.points = frame.points.size();
  r.dropped_no_return = frame.dropped_no_return_points;

  TerrainGrid grid(src.grid);
  grid.binPoints(frame.points);
  const Eigen::MatrixXf cloud = toPatchworkCloud(frame.points);
  auto pw = makePatchwork();
  for (CallScore& c : r.call) {
    pw->estimateGround(cloud);
    c = scoreCall(*pw, frame, grid, labels);
  }
  r.time = timeCalls(cloud, calls);
  // Only where the file holds the very points scored (a KITTI scan without no-returns dropped).
  if (fs::path(frame.source_path).extension() == ".bin" && r.dropped_no_return == 0 &&
      fs::file_size(frame.source_path) == std::uintmax_t(cloud.rows()) * 16)
    r.time_with_read = timeCalls(cloud, calls, frame.source_path);
  return r;
}

std::string f3(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.3f", v);
  return b;
}

void printTable(const std::vector<ScanResult>& results, int calls) {
  std::printf("%-22s %8s %7s %4s %6s %5s %4s %4s %6s %6s\n", "scan", "points", "no-ret", "call",
              "cells", "TP", "FP", "FN", "obs P", "obs R");
  for (const ScanResult& r : results) {
    for (int k = 0; k < 2; ++k) {
      const CallScore& c = r.call[k];
      std::printf("%-22s %8zu %7zu %4d %6llu %5llu %4llu %4llu %6s %6s\n", r.spec.name().c_str(),
                  r.points, r.dropped_no_return, k + 1,
                  static_cast<unsigned long long>(c.cells_scored),
                  static_cast<unsigned long long>(c.obstacle.tp),
                  static_cast<unsigned long long>(c.obstacle.fp),
                  static_cast<unsigned long long>(c.obstacle.fn),
                  f3(c.obstacle.precision()).c_str(), f3(c.obstacle.recall()).c_str());
      if (c.unassigned)
        std::printf(
            "  note: %zu points in neither of Patchwork++'s index lists (taken as ground)\n",
            c.unassigned);
    }
  }
  if (calls < 2) return;
  std::printf("\nestimateGround, one instance, %d calls, the first dropped [ms]:\n", calls);
  std::printf("%-22s %8s %8s %8s\n", "scan", "median", "min", "max");
  for (const ScanResult& r : results)
    std::printf("%-22s %8.2f %8.2f %8.2f\n", r.spec.name().c_str(), r.time.median_ms, r.time.min_ms,
                r.time.max_ms);
  bool any = false;
  for (const ScanResult& r : results) any = any || r.time_with_read.calls;
  if (!any) return;
  std::printf("\nreading the .bin + estimateGround, same calls [ms]:\n");
  std::printf("%-22s %8s %8s %8s\n", "scan", "median", "min", "max");
  for (const ScanResult& r : results)
    if (r.time_with_read.calls)
      std::printf("%-22s %8.2f %8.2f %8.2f\n", r.spec.name().c_str(), r.time_with_read.median_ms,
                  r.time_with_read.min_ms, r.time_with_read.max_ms);
}

void writeCsv(const std::string& path, const std::vector<ScanResult>& results) {
  std::ostringstream out;
  out << "scan,sweep,dataset,frame,points,dropped_no_return,call,cells_scored,obstacle_tp,"
         "obstacle_fp,obstacle_fn,obstacle_tn,obstacle_precision,obstacle_recall,unassigned,"
         "timed_calls,time_median_ms,time_min_ms,time_max_ms,time_with_read_median_ms\n";
  for (const ScanResult& r : results) {
    for (int k = 0; k < 2; ++k) {
      const CallScore& c = r.call[k];
      out << r.spec.name() << ',' << r.spec.sweep << ',' << r.spec.dataset << ',' << r.spec.frame
          << ',' << r.points << ',' << r.dropped_no_return << ',' << k + 1 << ',' << c.cells_scored
          << ',' << c.obstacle.tp << ',' << c.obstacle.fp << ',' << c.obstacle.fn << ','
          << c.obstacle.tn << ',' << f3(c.obstacle.precision()) << ',' << f3(c.obstacle.recall())
          << ',' << c.unassigned << ',' << r.time.calls << ',' << r.time.median_ms << ','
          << r.time.min_ms << ',' << r.time.max_ms << ',';
      if (r.time_with_read.calls) out << r.time_with_read.median_ms;
      out << '\n';
    }
  }
  writeFileAtomic(path, out.str());
}

int usage(const char* argv0, int code) {
  (code ? std::cerr : std::cout)
      << "usage: " << argv0 << " [--calls N] [--csv FILE] SWEEP.yaml:DATASET:FRAME ...\n"
      << "  Patchwork++ (" << PATCHWORK_ORIGIN << ") on each scan, read as the sweep's dataset\n"
      << "  DATASET reads it; obstacle precision/recall cell-wise on the sweep's grid for two\n"
      << "  calls, then N timed calls of estimateGround (default 30, the first dropped; 0: "
         "none).\n";
  return code;
}

int run(int argc, char** argv) {
  int calls = 30;
  std::string csv;
  std::vector<ScanSpec> scans;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "-h" || a == "--help") return usage(argv[0], 0);
    if ((a == "--calls" || a == "--csv") && i + 1 >= argc) {
      std::cerr << a << " needs a value\n";
      return usage(argv[0], 2);
    }
    if (a == "--calls") {
      const std::string v = argv[++i];
      char* end = nullptr;
      const long n = std::strtol(v.c_str(), &end, 10);
      if (v.empty() || *end || n < 0 || n > 100000) {
        std::cerr << "--calls: '" << v << "' is not a count from 0 to 100000\n";
        return 2;
      }
      calls = static_cast<int>(n);
    } else if (a == "--csv") {
      csv = argv[++i];
    } else if (a.rfind("--", 0) == 0) {
      std::cerr << "unknown option " << a << "\n";
      return usage(argv[0], 2);
    } else {
      scans.push_back(parseScan(a));
    }
  }
  if (scans.empty()) return usage(argv[0], 2);
  if (calls == 1) {
    std::cerr << "--calls: 1 leaves nothing once the first call is dropped; use 0 or >= 2\n";
    return 2;
  }

  const LabelSet labels = LabelSet::defaults();
  PluginRegistry registry(PluginRegistry::defaultSearchDirs());
  std::vector<ScanResult> results;
  for (const ScanSpec& s : scans) {
    if (!fs::exists(s.sweep)) throw InputError(s.sweep, "sweep file not found");
    results.push_back(compareScan(s, labels, registry, calls));
  }
  std::printf(
      "# Patchwork++ core: %s; default KITTI Params; obstacle cell-wise, cells holding "
      "labelled points\n",
      PATCHWORK_ORIGIN);
  printTable(results, calls);
  if (!csv.empty()) writeCsv(csv, results);
  return 0;
}

}  // namespace
}  // namespace terramrf

int main(int argc, char** argv) {
  try {
    return terramrf::run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "terramrf_patchwork_compare: " << e.what() << "\n";
    return 1;
  }
}
