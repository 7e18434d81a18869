// Gibbs sampler with simulated annealing (Geman & Geman 1984), the optimiser of papers 000/001.
// Each sweep draws every cell's label from its conditional P(k | neighbours) ∝ exp(−E_c(k) / T),
// E_c the eq. 12 local energy, colour by colour: the four parity classes of (row, column), none
// of which holds two 8-neighbours, so a colour's cells are conditionally independent and are
// drawn eight at a time (ColourPlanes, colourSweep). The temperature T follows an annealing
// schedule over the sweeps. The returned labelling is the lowest-energy one seen at the end of an
// annealing sweep (or the initial labelling), so the energy never rises above the start.
// The label marginals (the score layers) come from extra sweeps at one fixed temperature after the
// annealing: averages over a schedule's changing temperatures are marginals of no distribution.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "colour_planes.hpp"
#include "colour_sweep.hpp"
#include "terramrf/plugin.hpp"
#include "terramrf/simd.hpp"

namespace terramrf {

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
        .unit("sweeps")
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
        .unit("sweeps")
        .range(0, 100000);
    d.add("marginal_burn_in", marg_burn_in_,
          "sweeps at marginal_temperature before the marginal_sweeps, not averaged: the annealed "
          "state is usually colder than exp(−E/T_m)")
        .unit("sweeps")
        .range(0, 100000);
    d.add("burn_in", burn_in_,
          "with marginal_sweeps: 0 only, annealing sweeps before their conditionals are averaged")
        .unit("sweeps")
        .range(0, 100000);
    d.add("seed", seed_, "random seed; the same seed gives the same labelling and marginals")
        .unit("1")
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
    planes_.assign(em, em.initial);
    const double e_initial = em.energy(em.initial);
    double e = e_initial, e_best = e_initial;
    int best_sweep = -1;  // -1 = the initial labelling
    sums_.assign(4 * std::size_t(K) * planes_.planeSize(), 0.f);
    ColourSweepParams sp;
    sp.we = 2.f * em.beta;
    sp.wd = 2.f * em.beta_diagonal;
    sp.avx2 = useAvx2();
    const bool average_annealing = marg_sweeps_ == 0;
    // Sweeps are numbered across the annealing and the marginal chain: each has its own draws.
    uint64_t sweep_id = 0;
    auto run = [&](float inv_t, bool average, double& energy) {
      sp.inv_t = inv_t;
      sp.sums = average ? sums_.data() : nullptr;
      sp.keys = SweepKeys(static_cast<uint64_t>(seed_), sweep_id++);
      return colourSweep(planes_, sp, energy);
    };
    int changed = 0, sweep = 0;
    for (; sweep < sweeps_; ++sweep) {
      changed = run(static_cast<float>(1.0 / temperatureAt(sweep)),
                    average_annealing && sweep >= burn_in_, e);
      if (e < e_best) {
        e_best = e;
        best_sweep = sweep;
        best_ = planes_.data();
      }
    }
    // Where the annealing itself ended (the chain, not the best state it passed through).
    end_.assign(em.initial.begin(), em.initial.end());
    planes_.extract(em, end_);
    const double e_annealed = em.energy(end_);

    // The marginal chain continues from the annealed state; best_ keeps the result, and the
    // chain's energy is not tracked.
    int averaged = sweeps_ - burn_in_;
    if (!average_annealing) {
      const float inv_t = static_cast<float>(1.0 / t_marg_);
      double e_chain = e_annealed;
      for (int s = 0; s < marg_burn_in_ + marg_sweeps_; ++s)
        run(inv_t, s >= marg_burn_in_, e_chain);
      averaged = marg_sweeps_;
    }

    // The running energy is a float sum; the decision that keeps the promise "never above the
    // initial energy" is taken on exact totals.
    std::vector<uint8_t> lab = em.initial;
    if (best_sweep >= 0) {
      planes_.data() = best_;
      planes_.extract(em, lab);
    }
    double e_final = em.energy(lab);
    if (e_final > e_initial) {
      lab = em.initial;
      e_final = e_initial;
      best_sweep = -1;
    }
    marg_.assign(em.cells() * K, 0.f);
    planes_.gatherLabelSums(em, sums_, 1.f / static_cast<float>(averaged), marg_);

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
    em.writeGridLabels(lab, ctx.grid->labels());
    if (marg.empty() || !ctx.labels) return;
    const std::size_t n = em.cells();
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

  ColourPlanes planes_;
  std::vector<uint8_t> best_, end_;
  std::vector<float> sums_, marg_;
};

}  // namespace terramrf

TERRAMRF_PLUGIN(
    terramrf::GibbsSampler, terramrf::PluginKind::kOptimiser, "gibbs",
    "Gibbs sampler with simulated annealing; scores = label marginals of exp(−E/T_m) from "
    "sweeps after the annealing")
