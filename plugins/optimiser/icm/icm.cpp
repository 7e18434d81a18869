// Iterated conditional modes (Besag 1986): each cell in turn takes the label of lowest local
// energy given its neighbours, until a sweep changes nothing. Never raises the energy, so it is
// a fast, deterministic baseline next to the Gibbs sampler and α-expansion.
#include <limits>

#include "terramrf/padded_labels.hpp"
#include "terramrf/plugin.hpp"

namespace terramrf {

class Icm final : public Stage {
 public:
  void declare(ParamDecl& d) override {
    d.add("max_sweeps", max_sweeps_, "upper bound on full sweeps over the grid")
        .unit("sweeps")
        .range(1, 10000);
    d.add("report_energy", report_energy_,
          "compute the initial and final total energy for the report (costs two passes) and return "
          "the initial labelling should float rounding have ended above it; false reports both as "
          "NaN (not computed), never as a number that could be read as an energy");
  }
  std::vector<std::string> reads() const override { return {artefacts::kEnergy}; }
  std::vector<std::string> writes() const override { return {artefacts::kLabels}; }

  void process(FrameContext& ctx) override {
    const EnergyModel& em = ctx.energy;
    std::vector<uint8_t>& lab = labels_;
    lab = em.initial;
    OptimiserReport& rep = ctx.optimiser;
    rep = {};
    constexpr double kNotComputed = std::numeric_limits<double>::quiet_NaN();
    rep.initial_energy = report_energy_ ? em.energy(lab) : kNotComputed;
    padded_.assign(em, lab);
    bool converged = false;
    const int sweep = icmSweeps(em, padded_, max_sweeps_, dirty_, converged);
    padded_.extract(em, lab);
    rep.iterations = sweep;
    rep.converged = converged;
    rep.final_energy = report_energy_ ? em.energy(lab) : kNotComputed;
    // Labels are chosen on float local scores; where two labels' scores differ by less than their
    // rounding, a step can be uphill in the exact total. The promise "never above the initial
    // labelling" is kept on exact totals, as Gibbs and α-expansion keep it.
    bool returned_initial = false;
    if (report_energy_ && rep.final_energy > rep.initial_energy) {
      lab = em.initial;
      rep.final_energy = rep.initial_energy;
      rep.converged = false;
      returned_initial = true;
    }
    em.writeGridLabels(lab, ctx.grid->labels());
    ctx.metrics[name() + ".sweeps"] = sweep;
    if (report_energy_) {
      ctx.metrics[name() + ".energy"] = rep.final_energy;
      ctx.metrics[name() + ".initial_energy"] = rep.initial_energy;
      ctx.metrics[name() + ".returned_initial"] = returned_initial ? 1 : 0;
    }
  }

 private:
  int max_sweeps_ = 50;
  bool report_energy_ = true;
  std::vector<uint8_t> labels_, dirty_;
  PaddedLabels padded_;
};

}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::Icm, terramrf::PluginKind::kOptimiser, "icm",
                "iterated conditional modes: greedy per-cell minimisation until no label changes")
