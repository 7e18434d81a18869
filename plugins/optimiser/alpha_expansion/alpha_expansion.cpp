// α-expansion (Boykov, Veksler & Zabih 2001) with Kolmogorov's Boykov–Kolmogorov max-flow
// (Debian's libmaxflow), run only where a cut can still change (expansion_cuts.hpp).
//
// The Potts term of EnergyModel, w·δ with δ(equal) = −1 and δ(different) = +1, equals the metric
// V(a, b) = 2w·[a ≠ b] minus the constant w per pair, so minimising one minimises the other and
// α-expansion applies, with its factor-2 bound on the shifted energy (docs/optimisers.md). A move
// is kept only if the exact EnergyModel energy drops, so the result never lies above the start.
// Once no expansion improves, exact 2×2 block moves follow (`block_moves`, block_moves.hpp), and
// once those do not improve either, exact moves over strips two cells wide (`strip_moves`,
// strip_moves.hpp); after any accepted block or strip move the expansions run again.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "block_moves.hpp"
#include "expansion_cuts.hpp"
#include "frame_graph.hpp"
#include "strip_moves.hpp"
#include "terramrf/padded_labels.hpp"
#include "terramrf/plugin.hpp"
#include "terramrf/roc.hpp"

namespace terramrf {

using expansion::BlockMoves;
using expansion::isDiagonal;
using expansion::kDc;
using expansion::kDr;
using expansion::StripMoves;

class AlphaExpansion final : public Stage {
 public:
  void declare(ParamDecl& d) override {
    d.add("max_cycles", max_cycles_,
          "upper bound on cycles (one expansion per label); stops earlier when a cycle improves "
          "nothing")
        .unit("cycles")
        .range(1, 1000);
    d.add("init", init_,
          "starting labelling: the energy stage's initial labelling, or the per-cell unary argmin")
        .choices({"initial", "unary_argmin"});
    d.add("pre_icm", pre_icm_,
          "run ICM on the starting labelling before the expansions: the first, most expensive "
          "cuts then only make the moves ICM cannot (2× faster on the noisy benchmark start)");
    d.add("block_moves", block_moves_,
          "when no expansion improves, give each 2×2 block of cells its best joint labelling "
          "(moves in which two labels enter at once), then expand again; up to 8 labels");
    d.add("strip_moves", strip_moves_,
          "when neither expansions nor 2×2 blocks improve, give each strip of two rows or two "
          "columns its best joint labelling (dynamic programming; patches such as 4 × 2 that two "
          "labels enter), then expand again; up to 8 labels");
  }
  std::vector<std::string> reads() const override { return {artefacts::kEnergy}; }
  std::vector<std::string> writes() const override { return {artefacts::kLabels}; }

  void process(FrameContext& ctx) override {
    const EnergyModel& em = ctx.energy;
    const int K = em.numLabels();
    OptimiserReport& rep = ctx.optimiser;
    rep = {};
    if (K == 0 || em.cells() == 0) {  // nothing to label: every cell unknown
      ctx.grid->labels().assign(ctx.grid->cells(), labels::kUnknown);
      return;
    }
    const double e_initial = em.energy(em.initial);
    std::vector<uint8_t>& lab = lab_;
    lab = em.initial;
    if (init_ == "unary_argmin") {
      for (std::size_t i = 0; i < em.cells(); ++i) {
        if (em.fixed[i]) continue;
        const float* u = &em.unary[i * K];
        lab[i] = static_cast<uint8_t>(std::min_element(u, u + K) - u);
      }
    }
    int icm_sweeps = 0;
    if (pre_icm_) {
      bool icm_converged = false;
      pad_.assign(em, lab);
      icm_sweeps = icmSweeps(em, pad_, 100, dirty_, icm_converged);
      pad_.extract(em, lab);
    }

    cuts_.beginFrame(em);
    in_move_.assign(em.cells(), 0);

    double e = em.energy(lab);
    blocks_.beginFrame(em.cells());
    const bool strips = strip_moves_ && K >= 2 && K <= StripMoves::kMaxLabels;
    if (strips) strips_.beginFrame(em.rows, em.cols);
    int cycle = 0, expansions = 0, accepted = 0, block_passes = 0, strip_passes = 0;
    // An expansion that changed nothing need not be repeated until another one changes the
    // labelling: `version` counts accepted moves, failed_at[α] remembers when α last failed.
    int version = 0;
    std::vector<int> failed_at(K, -1);
    bool converged = false;
    while (cycle < max_cycles_ && !converged) {
      ++cycle;
      bool improved = false;
      for (int alpha = 0; alpha < K; ++alpha) {
        if (failed_at[alpha] == version) continue;
        ++expansions;
        bool better = false;
        if (cuts_.expand(em, lab, alpha)) {
          const double de = moveEnergyChange(em, lab, alpha);
          // Strict decrease beyond round-off, so equal-energy moves cannot cycle forever.
          if (de < -1e-9 * (1.0 + std::abs(e))) {
            for (int i : cuts_.move()) {
              lab[i] = static_cast<uint8_t>(alpha);
              cuts_.labelChanged(i);
              if (block_moves_) blocks_.touch(i, em.rows, em.cols);
              if (strips) strips_.touch(i);
            }
            e += de;
            better = improved = true;
            ++accepted;
            ++version;
          }
        }
        if (!better) failed_at[alpha] = version;
      }
      // Expansions are exhausted: try the moves they do not contain, and expand again if any
      // was taken.
      if (!improved && block_moves_ && K >= 2 && K <= BlockMoves::kMaxLabels) {
        relabelled_.clear();
        const double de = blocks_.pass(em, lab, relabelled_);
        for (int i : relabelled_) {
          cuts_.labelChanged(i);
          if (strips) strips_.touch(i);
        }
        if (de < 0) {
          e += de;
          improved = true;
          ++block_passes;
          ++version;
        }
      }
      // Then strips two cells wide, which hold the patches no 2×2 block holds.
      if (!improved && strips) {
        relabelled_.clear();
        const double de = strips_.pass(em, lab, relabelled_);
        for (int i : relabelled_) {
          cuts_.labelChanged(i);
          if (block_moves_) blocks_.touch(i, em.rows, em.cols);
        }
        if (de < 0) {
          e += de;
          improved = true;
          ++strip_passes;
          ++version;
        }
      }
      converged = !improved;
    }
    // The running energy is a sum of changes; the promise "never above the initial labelling"
    // is kept on exact totals (an argmin start can end above a good given initial labelling).
    e = em.energy(lab);
    bool returned_initial = false;
    if (e > e_initial) {
      lab = em.initial;
      e = e_initial;
      // No expansion was tried from the labelling returned: it is no local minimum of the moves,
      // and the counts below describe the run that was discarded.
      converged = false;
      returned_initial = true;
    }
    rep.initial_energy = e_initial;
    rep.final_energy = e;
    rep.iterations = cycle;
    rep.converged = converged;
    ctx.metrics[name() + ".returned_initial"] = returned_initial ? 1 : 0;
    writeOutputs(ctx, lab);
    ctx.metrics[name() + ".cycles"] = cycle;
    ctx.metrics[name() + ".expansions"] = expansions;
    ctx.metrics[name() + ".accepted_expansions"] = accepted;
    ctx.metrics[name() + ".icm_sweeps"] = icm_sweeps;
    ctx.metrics[name() + ".block_passes"] = block_passes;
    ctx.metrics[name() + ".block_moves"] = blocks_.taken();
    ctx.metrics[name() + ".strip_passes"] = strip_passes;
    ctx.metrics[name() + ".strip_moves"] = strips ? strips_.taken() : 0;
    ctx.metrics[name() + ".strip_stretches"] = strips ? strips_.searched() : 0;
    ctx.metrics[name() + ".strip_positions"] = strips ? strips_.searchedPositions() : 0;
    ctx.metrics[name() + ".max_flows"] = cuts_.maxFlows();
    ctx.metrics[name() + ".max_flow_nodes_per_cut"] =
        cuts_.maxFlows() ? double(cuts_.maxFlowNodes()) / cuts_.maxFlows() : 0.0;
    ctx.metrics[name() + ".max_flow_regrowths"] = cuts_.regrowths();
    ctx.metrics[name() + ".energy"] = e;
    ctx.metrics[name() + ".initial_energy"] = e_initial;
  }

 private:
  /// Exact energy change if the cells of the expansion's move take α (pairs inside the move counted
  /// once).
  double moveEnergyChange(const EnergyModel& em, const std::vector<uint8_t>& lab, int alpha) {
    const int R = em.rows, C = em.cols, K = em.numLabels();
    for (int i : cuts_.move()) in_move_[i] = 1;
    double de = 0;
    for (int i : cuts_.move()) {
      const int a = lab[i], r = i / C, c = i % C;
      de += double(em.unary[std::size_t(i) * K + alpha]) - em.unary[std::size_t(i) * K + a];
      for (int d = 0; d < 8; ++d) {
        const int rr = r + kDr[d], cc = c + kDc[d];
        if (rr < 0 || rr >= R || cc < 0 || cc >= C) continue;
        const int j = rr * C + cc;
        if (em.fixed[j] || (in_move_[j] && j < i)) continue;
        const int b_old = lab[j], b_new = in_move_[j] ? alpha : b_old;
        const double w = isDiagonal(d) ? em.beta_diagonal : em.beta;
        de += w * ((alpha == b_new ? -1.0 : 1.0) - (a == b_old ? -1.0 : 1.0));
      }
    }
    for (int i : cuts_.move()) in_move_[i] = 0;
    return de;
  }

  /// Grid labels (fixed → unknown) and score layers: the local energy margin
  /// min_{j≠k} E_c(j) − E_c(k) given the final neighbours, the score the ROC curves give an
  /// optimiser without score layers (ICM), so that deterministic optimisers are scored alike.
  void writeOutputs(FrameContext& ctx, const std::vector<uint8_t>& lab) {
    const EnergyModel& em = ctx.energy;
    auto& out = ctx.grid->labels();
    em.writeGridLabels(lab, out);
    if (!ctx.labels) return;
    std::vector<Layer> scores = localEnergyScores(em, out, ctx.labels->size());
    for (LabelId id : em.active)
      if (id < scores.size() && !scores[id].empty())
        ctx.grid->add(layers::score(ctx.labels->name(id))) = std::move(scores[id]);
  }

  int max_cycles_ = 10;
  std::string init_ = "initial";
  bool pre_icm_ = true;
  bool block_moves_ = true;
  bool strip_moves_ = true;

  expansion::ExpansionCuts cuts_;
  BlockMoves blocks_;
  StripMoves strips_;
  std::vector<int> relabelled_;  ///< cells a block or strip pass relabelled, in order
  std::vector<uint8_t> lab_, dirty_, in_move_;
  PaddedLabels pad_;  ///< the ICM start's labels
};

}  // namespace terramrf

TERRAMRF_PLUGIN(
    terramrf::AlphaExpansion, terramrf::PluginKind::kOptimiser, "alpha_expansion",
    "α-expansion graph cuts (Boykov–Kolmogorov max-flow on the regions a cut can change); scores = "
    "local energy margin")
