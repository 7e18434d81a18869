// The order and read/write check of a pipeline's plugins (config_internal.hpp, StageFlow).
#include "config_internal.hpp"

namespace terramrf::detail {

StageFlow::StageFlow(Diags& d) : d_(d) { addWrite(artefacts::kPoints); }

void StageFlow::addWrite(const std::string& w) {
  if (available_.insert(w).second) available_order_.push_back(w);
}

void StageFlow::checkReads(const Plugin& p, const YAML::Mark& m) {
  if (an_entry_failed_) return;
  for (const auto& r : p.reads()) {
    if (available_.count(r)) continue;
    std::string have;
    for (const auto& a : available_order_) have += (have.empty() ? "" : ", ") + a;
    d_.add(m, "reads '" + r + "', which no earlier stage writes (available here: " + have + ")",
           p.name(), p.type());
  }
}

void StageFlow::stage(const Plugin& p, PluginKind kind, const YAML::Mark& m) {
  if (kind == PluginKind::kEgomotion && !first_non_ego_.empty())
    d_.add(m,
           "egomotion stages must come before feature/energy/optimiser stages (the grid is built "
           "after the pose is known); this one follows " +
               first_non_ego_ + ", so it would run on a grid already built without it",
           p.name(), p.type());
  if (kind != PluginKind::kEgomotion && first_non_ego_.empty())
    first_non_ego_ = "'" + p.name() + "' (" + p.type() + ")";
  checkReads(p, m);
  for (const auto& w : p.writes()) addWrite(w);
}

void StageFlow::output(const Plugin& p, const YAML::Mark& m) { checkReads(p, m); }

}  // namespace terramrf::detail
