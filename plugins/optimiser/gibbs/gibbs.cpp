// Gibbs sampler with simulated annealing (Geman & Geman 1984), the optimiser of papers 000/001.
// Each sweep visits the cells in raster order and draws a cell's label from its conditional
// P(k | neighbours) ∝ exp(−E_c(k) / T), E_c the eq. 12 local energy; the temperature T follows an
// annealing schedule over the sweeps. The returned labelling is the lowest-energy one seen at the
// end of an annealing sweep (or the initial labelling), so the energy never rises above the start.
// The label marginals (the score layers) come from extra sweeps at one fixed temperature after the
// annealing: averages over a schedule's changing temperatures are marginals of no distribution.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "neg_exp_table.hpp"
#include "terramrf/padded_labels.hpp"
#include "terramrf/plugin.hpp"

namespace terramrf {
namespace {

/// PCG32 (O'Neill 2014, XSH-RR): one 64-bit multiply per draw, several times faster than
/// std::mt19937 for the one draw per cell update, and fully determined by the seed.
class Pcg32 {
 public:
  explicit Pcg32(uint64_t seed) {
    state_ = 0;
    next();
    state_ += seed;
    next();
  }
  uint32_t next() {
    const uint64_t old = state_;
    state_ = old * 6364136223846793005ULL + kIncrement;
    const uint32_t xorshifted = static_cast<uint32_t>(((old >> 18u) ^ old) >> 27u);
    const uint32_t rot = static_cast<uint32_t>(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((32u - rot) & 31u));
  }
  /// Uniform in [0, 1) with 24 bits (a float's mantissa).
  float uniform() { return static_cast<float>(next() >> 8) * (1.0f / 16777216.0f); }

 private:
  static constexpr uint64_t kIncrement = 1442695040888963407ULL;
  uint64_t state_;
};

}  // namespace

class GibbsSampler final : public Stage {
 public:
  void declare(ParamDecl& d) override {
    d.add("temperature", t0_, "start temperature T0 of the Gibbs distribution exp(−E/T)")
        .unit("energy")
        .range(1e-6, 1e6);
    d.add("final_temperature", t_end_,
          "temperature of the last sweep (geometric, linear) or lower bound (logarithmic)")
        .unit("energy")
        .range(1e-6, 1e6);
    d.add("schedule", schedule_,
          "annealing schedule: geometric T0·(Tf/T0)^(s/(S−1)), linear from T0 to Tf, "
          "logarithmic max(Tf, T0/(1 + rate·ln(1+s))), or constant T0 (plain sampling)")
        .choices({"geometric", "logarithmic", "linear", "constant"});
    d.add("rate", rate_, "speed of the logarithmic schedule (unused by the others)")
        .unit("1")
        .range(0, 1e6);
    d.add("sweeps", sweeps_,
          "annealing sweeps over the grid; the result is the lowest-energy labelling they reach")
        .range(1, 100000);
    d.add("marginal_temperature", t_marg_,
          "temperature T_m of the score layers: they estimate the per-cell marginals of "
          "exp(−E/T_m) (1 = the posterior when E is a negative log-probability)")
        .unit("energy")
        .range(1e-6, 1e6);
    d.add("marginal_sweeps", marg_sweeps_,
          "sweeps at marginal_temperature after the annealing, from its final state, whose "
          "conditionals are averaged into the marginals; they never change the returned "
          "labelling. 0 = average the annealing sweeps after burn_in instead (cheaper, but with "
          "an annealing schedule that mixes temperatures: marginals of exp(−E/T0) only with "
          "schedule: constant)")
        .range(0, 100000);
    d.add("marginal_burn_in", marg_burn_in_,
          "sweeps at marginal_temperature before the marginal_sweeps, not averaged: the annealed "
          "state is usually colder than exp(−E/T_m)")
        .range(0, 100000);
    d.add("burn_in", burn_in_,
          "with marginal_sweeps: 0 only, annealing sweeps before their conditionals are averaged")
        .range(0, 100000);
    d.add("seed", seed_, "random seed; the same seed gives the same labelling and marginals")
        .range(0, 4294967295.0);
  }

  void configure(const PluginContext& /*ctx*/) override {
    if (marg_sweeps_ == 0 && burn_in_ >= sweeps_)
      throw ParamError("burn_in", "burn_in (" + std::to_string(burn_in_) +
                                      ") must be smaller than sweeps (" + std::to_string(sweeps_) +
                                      ") so that some samples are averaged (marginal_sweeps: 0)");
    if (schedule_ != "constant" && t_end_ > t0_)
      throw ParamError("final_temperature", "final_temperature must not exceed temperature (" +
                                                std::to_string(t0_) + ") when annealing");
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
    if (K > 255)
      throw InputError("", name() + ": " + std::to_string(K) + " labels; at most 255 supported");
    pad_.assign(em, em.initial);
    best_ = pad_;
    const double e_initial = em.energy(em.initial);
    double e = e_initial, e_best = e_initial;
    int best_sweep = -1;  // -1 = the initial labelling
    marg_.assign(em.cells() * K, 0.f);
    Pcg32 rng(static_cast<uint64_t>(seed_));
    const bool average_annealing = marg_sweeps_ == 0;
    int changed = 0, sweep = 0;
    for (; sweep < sweeps_; ++sweep) {
      const float inv_t = static_cast<float>(1.0 / temperatureAt(sweep));
      changed = runSweep(em, inv_t, average_annealing && sweep >= burn_in_, rng, e);
      if (e < e_best) {
        e_best = e;
        best_sweep = sweep;
        std::memcpy(best_.data().data(), pad_.data().data(), pad_.data().size());
      }
    }
    // Where the annealing itself ended (the chain, not the best state it passed through).
    end_.assign(em.initial.begin(), em.initial.end());
    pad_.extract(em, end_);
    const double e_annealed = em.energy(end_);

    // The marginal chain continues from the annealed state on pad_ only; best_ keeps the result,
    // and its energy is not tracked.
    int averaged = sweeps_ - burn_in_;
    if (!average_annealing) {
      const float inv_t = static_cast<float>(1.0 / t_marg_);
      double e_chain = e_annealed;
      for (int s = 0; s < marg_burn_in_ + marg_sweeps_; ++s)
        runSweep(em, inv_t, s >= marg_burn_in_, rng, e_chain);
      averaged = marg_sweeps_;
    }

    // The running energy is a float sum; the decision that keeps the promise "never above the
    // initial energy" is taken on exact totals.
    std::vector<uint8_t> lab = em.initial;
    if (best_sweep >= 0) best_.extract(em, lab);
    double e_final = em.energy(lab);
    if (e_final > e_initial) {
      lab = em.initial;
      e_final = e_initial;
      best_sweep = -1;
    }
    const float inv_n = 1.f / static_cast<float>(averaged);
    for (float& v : marg_) v *= inv_n;

    rep.initial_energy = e_initial;
    rep.final_energy = e_final;
    rep.iterations = sweep;
    rep.converged = changed == 0;  // frozen: the last annealing sweep changed no label
    writeOutputs(ctx, lab, marg_);
    ctx.metrics[name() + ".sweeps"] = sweep;
    ctx.metrics[name() + ".energy"] = e_final;
    ctx.metrics[name() + ".initial_energy"] = e_initial;
    ctx.metrics[name() + ".annealed_energy"] = e_annealed;
    ctx.metrics[name() + ".best_sweep"] = best_sweep;
    ctx.metrics[name() + ".last_sweep_changes"] = changed;
    ctx.metrics[name() + ".marginal_sweeps"] = average_annealing ? 0 : marg_burn_in_ + marg_sweeps_;
  }

 private:
  /// One sweep with the compile-time K for the usual label counts, which lets the compiler keep
  /// the K scores in registers.
  int runSweep(const EnergyModel& em, float inv_t, bool average, Pcg32& rng, double& e) {
    switch (em.numLabels()) {
      case 2:
        return sweepGrid<2>(em, inv_t, average, rng, e);
      case 3:
        return sweepGrid<3>(em, inv_t, average, rng, e);
      case 4:
        return sweepGrid<4>(em, inv_t, average, rng, e);
      case 5:
        return sweepGrid<5>(em, inv_t, average, rng, e);
      case 6:
        return sweepGrid<6>(em, inv_t, average, rng, e);
      default:
        return sweepGrid<0>(em, inv_t, average, rng, e);
    }
  }

  /// One Gibbs sweep in raster order over pad_ (KK = K, or 0 for any K); returns the number of
  /// labels changed and keeps `e` equal to the energy of the current labelling.
  template <int KK>
  int sweepGrid(const EnergyModel& em, float inv_t, bool average, Pcg32& rng, double& e) {
    const int R = em.rows, C = em.cols, K = KK > 0 ? KK : em.numLabels(), W = pad_.stride();
    // E_c(k) = u_k + Σ_n w_n − 2 Σ_{n: l_n = k} w_n; the middle sum is the same for every k and
    // cancels in the conditional, so localScores keeps only u_k − 2 Σ w_n.
    float s[KK > 0 ? KK + 1 : 256], q[KK > 0 ? KK : 255];
    int changed = 0;
    for (int r = 0; r < R; ++r) {
      uint8_t* p = pad_.at(r, 0);
      for (int c = 0; c < C; ++c, ++p) {
        if (*p == K) continue;  // fixed cell
        const std::size_t i = std::size_t(r) * C + c;
        localScores<KK>(em, p, i, W, s);
        // First least score, without branches: which label wins is a coin toss to a predictor.
        int arg = 0;
        float m = s[0];
        for (int k = 1; k < K; ++k) {
          const bool lower = s[k] < m;
          m = lower ? s[k] : m;
          arg = lower ? k : arg;
        }
        // Peaked conditional (every other label beyond the table's e^−32, where it gives 0): the
        // draw is certain, so it costs neither exponentials nor a random number. That is known
        // from the exponents alone, and most cells of the colder sweeps are certain.
        float x[KK > 0 ? KK : 255];
        bool certain = true;
        for (int k = 0; k < K; ++k) {
          x[k] = (s[k] - m) * inv_t;
          certain = certain && (k == arg || NegExpTable::zero(x[k]));
        }
        float sum = 0.f;
        int pick = arg;
        if (!certain) {
          for (int k = 0; k < K; ++k) {
            q[k] = k == arg ? 1.f : exp_(x[k]);
            sum += q[k];
          }
          // Inverse CDF; the last label absorbs rounding so a draw always lands somewhere.
          float u = rng.uniform() * sum;
          pick = K - 1;
          for (int k = 0; k < K - 1; ++k) {
            u -= q[k];
            if (u < 0.f) {
              pick = k;
              break;
            }
          }
        }
        const int old = *p;
        if (pick != old) {
          e += double(s[pick]) - double(s[old]);
          *p = static_cast<uint8_t>(pick);
          ++changed;
        }
        if (average) {
          // Rao-Blackwellised: averaging the conditionals instead of the drawn indicators gives
          // the same expectation with lower variance (smoother scores for ROC curves).
          float* acc = &marg_[i * K];
          if (certain) {
            acc[arg] += 1.f;
          } else {
            const float inv = 1.f / sum;
            for (int k = 0; k < K; ++k) acc[k] += q[k] * inv;
          }
        }
      }
    }
    return changed;
  }

  double temperatureAt(int s) const {
    const double f = sweeps_ > 1 ? double(s) / (sweeps_ - 1) : 1.0;
    if (schedule_ == "geometric") return t0_ * std::pow(t_end_ / t0_, f);
    if (schedule_ == "linear") return t0_ + (t_end_ - t0_) * f;
    if (schedule_ == "logarithmic") return std::max(t_end_, t0_ / (1.0 + rate_ * std::log1p(s)));
    return t0_;  // constant
  }

  /// Grid labels (fixed → unknown) and one marginal layer per active class (NaN on fixed cells).
  void writeOutputs(FrameContext& ctx, const std::vector<uint8_t>& lab,
                    const std::vector<float>& marg) const {
    const EnergyModel& em = ctx.energy;
    auto& out = ctx.grid->labels();
    out.assign(ctx.grid->cells(), labels::kUnknown);
    const std::size_t n = std::min(out.size(), em.cells());
    for (std::size_t i = 0; i < n; ++i)
      if (!em.fixed[i]) out[i] = em.active[lab[i]];
    if (marg.empty() || !ctx.labels) return;
    const int K = em.numLabels();
    for (int k = 0; k < K; ++k) {
      Layer& l = ctx.grid->add(layers::score(ctx.labels->name(em.active[k])));
      for (std::size_t i = 0; i < n; ++i)
        if (!em.fixed[i]) l[i] = marg[i * K + k];
    }
  }

  double t0_ = 1.0;
  double t_end_ = 0.05;
  std::string schedule_ = "geometric";
  double rate_ = 1.0;
  int sweeps_ = 100;
  double t_marg_ = 1.0;
  int marg_sweeps_ = 20;
  int marg_burn_in_ = 5;
  int burn_in_ = 20;
  int64_t seed_ = 1;

  NegExpTable exp_;
  PaddedLabels pad_, best_;
  std::vector<float> marg_;
  std::vector<uint8_t> end_;
};

}  // namespace terramrf

TERRAMRF_PLUGIN(
    terramrf::GibbsSampler, terramrf::PluginKind::kOptimiser, "gibbs",
    "Gibbs sampler with simulated annealing; scores = label marginals of exp(−E/T_m) from "
    "sweeps after the annealing")
