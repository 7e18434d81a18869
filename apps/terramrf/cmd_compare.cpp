// terramrf compare SWEEP.yaml [--out DIR]: feature sets × optimisers × datasets, trained on the
// sweep's train split, evaluated on its test split; tables like paper 000 Tables 1–3 and paper
// 001 Tables I–III, ROC plots. The logic is runSweep (sweep.hpp); formats in docs/compare.md.
#include <iostream>

#include "commands.hpp"
#include "terramrf/stop_request.hpp"
#include "terramrf/sweep.hpp"

namespace terramrf::cli {

int cmdCompare(const Args& args) {
  Args a = args;
  if (a.empty() || a[0].rfind("--", 0) == 0) {
    std::cerr << "usage: terramrf compare SWEEP.yaml [--out DIR] [--limit N] [--dry-run] "
                 "[--no-progress]\n";
    return kUsage;
  }
  CompareOptions o;
  o.sweep_path = a[0];
  a.erase(a.begin());
  o.output_dir = takeOption(a, "--out");
  if (!takeCount(a, "--limit", "compare", 1, o.limit)) return kUsage;
  const bool dry = takeFlag(a, "--dry-run");
  o.progress = !takeFlag(a, "--no-progress");
  if (!a.empty()) {
    std::cerr << "terramrf compare: unexpected argument '" << a[0] << "'\n";
    return kUsage;
  }
  try {
    if (dry) {
      const SweepPlan plan = planSweep(o.sweep_path);
      std::cout << "sweep '" << plan.name << "': " << plan.runs.size() << " run(s)";
      if (!plan.skipped.empty()) std::cout << ", " << plan.skipped.size() << " skipped";
      if (!plan.selection_runs.empty())
        std::cout << " after " << plan.selection_runs.size() << " validation run(s) of select:";
      std::cout << "\n";
      for (const auto& r : plan.selection_runs) std::cout << "  select " << r << "\n";
      for (const auto& r : plan.runs) std::cout << "  run   " << r << "\n";
      for (const auto& [r, why] : plan.skipped) std::cout << "  skip  " << r << ": " << why << "\n";
      for (const auto& n : plan.notes) std::cout << "note: " << n << "\n";
      return kOk;
    }
    const SweepResult r = runSweep(o);
    std::size_t ok = 0, skipped = 0, failed = 0;
    for (const auto& x : r.runs) {
      ok += x.status == RunRecord::Status::kOk;
      skipped += x.status == RunRecord::Status::kSkipped;
      failed += x.status == RunRecord::Status::kFailed;
    }
    for (const auto& sel : r.selections)
      std::cout << "selected on validation for " << sel.feature_set << ": "
                << (sel.chosen < 0 ? std::string("none (no candidate could be scored)")
                                   : sel.candidates[sel.chosen])
                << "\n";
    for (const auto& ds : r.datasets)
      for (const auto& op : r.optimisers)
        std::cout << "\n"
                  << ds << ", optimiser " << op << " (cell-wise):\n"
                  << accuracyTable(r, ds, op);
    for (const auto& ds : r.datasets)
      std::cout << "\nRuntime per scan, " << ds << ":\n" << runtimeTable(r, ds);
    std::cout << "\n" << ok << " run(s) ok, " << skipped << " skipped, " << failed << " failed\n";
    for (const auto& x : r.runs)
      if (x.status != RunRecord::Status::kOk)
        std::cout << "  " << (x.status == RunRecord::Status::kSkipped ? "skipped " : "failed  ")
                  << x.dataset << " × " << x.feature_set << " × " << x.optimiser << ": " << x.reason
                  << "\n";
    for (const auto& m : r.models)
      for (const auto& [frame, why] : m.failed)
        std::cout << "  training frame " << frame << " of feature set " << m.feature_set
                  << " failed and was skipped: " << why << "\n";
    for (const auto& x : r.runs)
      for (const auto& [frame, why] : x.failed)
        std::cout << "  frame " << frame << " of " << x.dataset << " × " << x.feature_set << " × "
                  << x.optimiser << " failed and was skipped: " << why << "\n";
    if (r.stop_signal != 0)
      std::cout << "compare interrupted (" << signalName(r.stop_signal)
                << "): the run or training in hand stopped after its frame in hand (failed "
                   "above), those after it were not run (exit status "
                << r.exitCode() << ")\n";
    std::cout << "report: " << r.output_dir << "/summary.md\n";
    return r.exitCode();
  } catch (const ConfigError& e) {
    for (const auto& d : e.diagnostics()) std::cerr << d.str() << "\n";
    std::cerr << e.diagnostics().size() << " error(s) in " << o.sweep_path << "; nothing was run\n";
    return kUsage;
  }
}

}  // namespace terramrf::cli
