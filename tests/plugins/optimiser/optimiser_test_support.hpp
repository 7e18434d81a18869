#pragma once
// Shared by the icm, gibbs and alpha_expansion tests: random energy models with known seeds, a
// harness that runs an optimiser plugin on a hand-filled FrameContext, and brute force for tiny
// grids.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "terramrf/param_values.hpp"
#include "terramrf/registry.hpp"
#include "test_support.hpp"

namespace terramrf::test {

/// Unknown plus four classes, so models with up to 4 active labels map index k → LabelId k + 1.
inline LabelSet optimiserLabelSet() {
  return LabelSet({{"unknown", {0, 0, 0}},
                   {"road", {128, 128, 128}},
                   {"rough", {139, 90, 43}},
                   {"obstacle", {220, 30, 30}},
                   {"vegetation", {30, 160, 30}}});
}

struct RandomModelSpec {
  int size = 12;   ///< grid rows, and columns unless `cols` is set [cells]
  int cols = 0;    ///< grid columns; 0 = square (`size`) [cells]
  int labels = 3;  ///< K (≤ 4)
  double fixed_fraction = 0.1;
  double unary_lo = -1.0, unary_hi = 1.0;
  double beta_lo = 0.2, beta_hi = 1.2;  ///< beta and beta_diagonal drawn independently
};

/// A random model: uniform unaries, random weights, random fixed cells and initial labels.
inline EnergyModel randomModel(uint32_t seed, const RandomModelSpec& s = {}) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unary(s.unary_lo, s.unary_hi), beta(s.beta_lo, s.beta_hi),
      coin(0, 1);
  std::uniform_int_distribution<int> label(0, s.labels - 1);
  EnergyModel em;
  em.resize(s.size, s.cols > 0 ? s.cols : s.size, s.labels);
  for (int k = 0; k < s.labels; ++k) em.active[k] = static_cast<LabelId>(k + 1);
  for (auto& u : em.unary) u = static_cast<float>(unary(rng));
  for (std::size_t i = 0; i < em.cells(); ++i) {
    em.fixed[i] = coin(rng) < s.fixed_fraction ? 1 : 0;
    em.initial[i] = static_cast<uint8_t>(label(rng));
  }
  em.beta = static_cast<float>(beta(rng));
  em.beta_diagonal = static_cast<float>(beta(rng));
  return em;
}

/// Number of unordered 8-neighbour pairs of non-fixed cells weighted by w: Σ_pairs w.
inline double pairWeightSum(const EnergyModel& em) {
  double s = 0;
  static const int dr[4] = {0, 1, 1, 1}, dc[4] = {1, 0, 1, -1};
  for (int r = 0; r < em.rows; ++r)
    for (int c = 0; c < em.cols; ++c) {
      if (em.fixed[r * em.cols + c]) continue;
      for (int n = 0; n < 4; ++n) {
        const int rr = r + dr[n], cc = c + dc[n];
        if (rr < 0 || rr >= em.rows || cc < 0 || cc >= em.cols || em.fixed[rr * em.cols + cc])
          continue;
        s += (dr[n] != 0 && dc[n] != 0) ? em.beta_diagonal : em.beta;
      }
    }
  return s;
}

/// Unary part of the energy (fixed cells ignored).
inline double dataEnergy(const EnergyModel& em, const std::vector<uint8_t>& lab) {
  double e = 0;
  for (std::size_t i = 0; i < em.cells(); ++i)
    if (!em.fixed[i]) e += em.unary[i * em.numLabels() + lab[i]];
  return e;
}

/// Global minimum by enumeration (K^cells labellings; keep it tiny). Fixed cells keep `initial`.
inline std::pair<double, std::vector<uint8_t>> bruteForce(const EnergyModel& em) {
  const int K = em.numLabels();
  std::vector<int> free_cells;
  for (std::size_t i = 0; i < em.cells(); ++i)
    if (!em.fixed[i]) free_cells.push_back(static_cast<int>(i));
  std::vector<uint8_t> lab = em.initial, best = lab;
  double e_best = std::numeric_limits<double>::infinity();
  long total = 1;
  for (std::size_t n = 0; n < free_cells.size(); ++n) total *= K;
  for (long code = 0; code < total; ++code) {
    long x = code;
    for (int i : free_cells) {
      lab[i] = static_cast<uint8_t>(x % K);
      x /= K;
    }
    const double e = em.energy(lab);
    if (e < e_best) {
      e_best = e;
      best = lab;
    }
  }
  return {e_best, best};
}

/// Exact per-cell marginals of exp(−E/T) by enumeration (cells × K, row-major by cell; fixed
/// cells keep `initial` and get 0). Keep it tiny: K^cells labellings.
inline std::vector<double> bruteForceMarginals(const EnergyModel& em, double T) {
  const int K = em.numLabels();
  std::vector<int> free_cells;
  for (std::size_t i = 0; i < em.cells(); ++i)
    if (!em.fixed[i]) free_cells.push_back(static_cast<int>(i));
  long total = 1;
  for (std::size_t n = 0; n < free_cells.size(); ++n) total *= K;
  // Energies relative to the minimum keep exp() away from overflow at low T.
  std::vector<double> e(total);
  std::vector<uint8_t> lab = em.initial;
  for (long code = 0; code < total; ++code) {
    long x = code;
    for (int i : free_cells) {
      lab[i] = static_cast<uint8_t>(x % K);
      x /= K;
    }
    e[code] = em.energy(lab);
  }
  const double e_min = *std::min_element(e.begin(), e.end());
  std::vector<double> marg(em.cells() * K, 0.0);
  double z = 0;
  for (long code = 0; code < total; ++code) {
    const double p = std::exp(-(e[code] - e_min) / T);
    z += p;
    long x = code;
    for (int i : free_cells) {
      marg[std::size_t(i) * K + x % K] += p;
      x /= K;
    }
  }
  for (double& m : marg) m /= z;
  return marg;
}

/// Lowest energy over all α-expansion moves from `lab` (every subset of the non-α, non-fixed
/// cells taking α), by enumeration.
inline double bestExpansionEnergy(const EnergyModel& em, const std::vector<uint8_t>& lab,
                                  int alpha) {
  std::vector<int> movable;
  for (std::size_t i = 0; i < em.cells(); ++i)
    if (!em.fixed[i] && lab[i] != alpha) movable.push_back(static_cast<int>(i));
  double best = em.energy(lab);
  std::vector<uint8_t> move = lab;
  for (uint32_t code = 1; code < (1u << movable.size()); ++code) {
    for (std::size_t b = 0; b < movable.size(); ++b)
      move[movable[b]] = (code >> b) & 1 ? static_cast<uint8_t>(alpha) : lab[movable[b]];
    best = std::min(best, em.energy(move));
  }
  return best;
}

/// Reference α-expansion with every move found by enumeration: labels in order, a move kept
/// only if it lowers the energy by more than round-off, until a cycle keeps none or after
/// `max_cycles` cycles (the plugin's parameter of the same name). `repeats`
/// counts expansions of a label whose earlier expansion saw another labelling (the plugin's
/// warm-started cuts with changed capacities). Keep the grids tiny: each move enumerates
/// 2^(movable cells) labellings.
inline std::vector<uint8_t> referenceExpansion(const EnergyModel& em, int* cycles,
                                               int* repeats = nullptr, int max_cycles = 1000) {
  int unused = 0;
  if (!repeats) repeats = &unused;
  std::vector<uint8_t> lab = em.initial;
  double e = em.energy(lab);
  *cycles = *repeats = 0;
  int version = 0;
  std::vector<int> seen(em.numLabels(), -1);
  for (bool improved = true; improved && *cycles < max_cycles;) {
    improved = false;
    ++*cycles;
    for (int alpha = 0; alpha < em.numLabels(); ++alpha) {
      *repeats += seen[alpha] >= 0 && seen[alpha] != version;
      std::vector<int> movable;
      for (std::size_t i = 0; i < em.cells(); ++i)
        if (!em.fixed[i] && lab[i] != alpha) movable.push_back(static_cast<int>(i));
      std::vector<uint8_t> move = lab, best = lab;
      double e_best = e;
      for (uint32_t code = 1; code < (1u << movable.size()); ++code) {
        for (std::size_t b = 0; b < movable.size(); ++b)
          move[movable[b]] = (code >> b) & 1 ? static_cast<uint8_t>(alpha) : lab[movable[b]];
        const double en = em.energy(move);
        if (en < e_best) e_best = en, best = move;
      }
      if (e_best < e - 1e-9 * (1.0 + std::abs(e))) {
        lab = best;
        e = e_best;
        improved = true;
        ++version;
      }
      seen[alpha] = version;
    }
  }
  return lab;
}

/// What one optimiser run produced.
struct OptimiserRun {
  std::vector<LabelId> grid_labels;
  std::vector<uint8_t> indices;  ///< label index per cell; 255 where the grid label is unknown
  std::map<std::string, Layer> scores;  ///< by class name
  OptimiserReport report;
  std::map<std::string, double> metrics;
};

/// Runs an optimiser plugin the way the pipeline does: a frame with no points, a grid of the
/// model's size, the label set, and the model in ctx.energy.
class OptimiserHarness {
 public:
  OptimiserHarness() : labels_(optimiserLabelSet()), reg_({pluginDir()}) {}

  std::unique_ptr<Stage> make(const std::string& type, const std::string& params,
                              const EnergyModel& em) {
    std::unique_ptr<Plugin> p = reg_.create(type);
    p->setIdentity(type, type);
    setParams(*p, params, pluginContext(em));
    auto* s = dynamic_cast<Stage*>(p.get());
    if (!s) {
      ADD_FAILURE() << type << " is not a Stage";
      return nullptr;
    }
    p.release();
    return std::unique_ptr<Stage>(s);
  }

  OptimiserRun run(const std::string& type, const std::string& params, const EnergyModel& em) {
    auto stage = make(type, params, em);
    if (!stage) return {};
    return run(*stage, em);
  }

  OptimiserRun run(Stage& stage, const EnergyModel& em) {
    Frame frame;
    frame.id = "000000";
    TerrainGrid grid(geometry(em));
    FrameContext ctx;
    ctx.frame = &frame;
    ctx.grid = &grid;
    ctx.labels = &labels_;
    ctx.energy = em;
    stage.process(ctx);
    OptimiserRun out;
    out.grid_labels = grid.labels();
    out.indices.assign(out.grid_labels.size(), 255);
    for (std::size_t i = 0; i < out.grid_labels.size(); ++i)
      for (int k = 0; k < em.numLabels(); ++k)
        if (out.grid_labels[i] == em.active[k]) out.indices[i] = static_cast<uint8_t>(k);
    for (int k = 0; k < em.numLabels(); ++k) {
      const std::string cls = labels_.name(em.active[k]);
      if (grid.has(layers::score(cls))) out.scores[cls] = grid.layer(layers::score(cls));
    }
    out.report = ctx.optimiser;
    out.metrics = ctx.metrics;
    return out;
  }

  /// Labelling as label indices for EnergyModel::energy (fixed cells take `initial`, which the
  /// energy ignores).
  static std::vector<uint8_t> labelling(const OptimiserRun& r, const EnergyModel& em) {
    std::vector<uint8_t> lab = em.initial;
    for (std::size_t i = 0; i < em.cells(); ++i)
      if (!em.fixed[i]) lab[i] = r.indices[i];
    return lab;
  }

  const LabelSet& labels() const { return labels_; }

  static GridGeometry geometry(const EnergyModel& em) {
    GridGeometry g;
    g.cell_m = 1.0;
    g.size_m = em.cols;
    return g;
  }
  PluginContext pluginContext(const EnergyModel& em) const {
    PluginContext c;
    c.grid = geometry(em);
    c.labels = &labels_;
    return c;
  }

 private:
  LabelSet labels_;
  PluginRegistry reg_;
};

/// The invariants every optimiser owes the pipeline: fixed cells unknown, every other cell one
/// of the active labels, energy not above the initial labelling's, report consistent.
inline void expectValidResult(const OptimiserRun& r, const EnergyModel& em,
                              const std::string& what) {
  SCOPED_TRACE(what);
  ASSERT_EQ(r.grid_labels.size(), em.cells());
  int bad = 0;
  for (std::size_t i = 0; i < em.cells(); ++i) {
    if (em.fixed[i]) {
      bad += r.grid_labels[i] != labels::kUnknown;
    } else {
      bad += r.indices[i] == 255;
    }
  }
  EXPECT_EQ(bad, 0) << "cells with a wrong kind of label";
  if (bad) return;
  const double e_init = em.energy(em.initial);
  const double e = em.energy(OptimiserHarness::labelling(r, em));
  EXPECT_NEAR(r.report.initial_energy, e_init, 1e-6 * (1 + std::abs(e_init)));
  EXPECT_NEAR(r.report.final_energy, e, 1e-6 * (1 + std::abs(e)));
  EXPECT_LE(e, e_init + 1e-9) << "energy rose above the initial labelling's";
}

}  // namespace terramrf::test
