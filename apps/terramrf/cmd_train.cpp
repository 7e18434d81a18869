// terramrf train CONFIG --data DIR... --out MODEL: learns a potts_gaussian model (per-class
// feature mean/σ, paper 000 §4.6) from annotated frames. The logic is trainModel (sweep.hpp).
#include <iostream>
#include <sstream>

#include "commands.hpp"
#include "terramrf/stop_request.hpp"
#include "terramrf/sweep.hpp"

namespace terramrf::cli {

int cmdTrain(const Args& args) {
  Args a = args;
  if (a.empty() || a[0].rfind("--", 0) == 0) {
    std::cerr << "usage: terramrf train CONFIG --out MODEL [--data DIR]... [--features a,b,...]\n"
                 "                      [--limit N] [--no-progress]\n";
    return kUsage;
  }
  TrainOptions o;
  o.config_path = a[0];
  a.erase(a.begin());
  for (std::string d; !(d = takeOption(a, "--data")).empty();) o.data.push_back(d);
  o.model_out = takeOption(a, "--out");
  std::stringstream feats(takeOption(a, "--features"));
  for (std::string f; std::getline(feats, f, ',');)
    if (!f.empty()) o.features.push_back(f);
  if (!takeCount(a, "--limit", "train", 1, o.limit)) return kUsage;
  o.progress = !takeFlag(a, "--no-progress");
  if (!a.empty()) {
    std::cerr << "terramrf train: unexpected argument '" << a[0] << "'\n";
    return kUsage;
  }
  if (o.model_out.empty()) {
    std::cerr << "terramrf train: --out MODEL is required (the model file to write)\n";
    return kUsage;
  }
  TrainResult r;
  try {
    r = trainModel(o);
  } catch (const ConfigError& e) {
    for (const auto& d : e.diagnostics()) std::cerr << d.str() << "\n";
    std::cerr << e.diagnostics().size() << " error(s) in " << o.config_path
              << "; nothing was trained\n";
    return kUsage;
  } catch (const std::exception& e) {
    // Stopped by SIGINT/SIGTERM (stop_request.hpp): trainModel says what it kept.
    if (const int sig = stopRequested()) {
      std::cerr << "terramrf train: " << e.what() << "\n";
      return 128 + sig;
    }
    throw;
  }
  std::cout << "model: " << r.model_path << "\n"
            << "trained on " << r.labelled_frames << " labelled of " << r.frames
            << " frame(s) from " << r.items.size() << " data item(s):\n";
  for (const auto& it : r.items)
    std::cout << "  " << (it.path.empty() ? it.label : it.path) << " (" << it.frames.str() << ", "
              << it.frame_ids.size() << " processed, " << it.labelled_frames << " labelled)\n";
  std::cout << "features:";
  for (const auto& f : r.features) std::cout << " " << f;
  std::cout << "\n";
  if (!r.missing.empty()) {
    std::cout << "not learnt (fewer than two training cells):";
    for (const auto& m : r.missing) std::cout << " " << m;
    std::cout << "\n";
  }
  if (!r.failed.empty()) {
    std::cout << r.failed.size() << " frame(s) failed and were skipped:\n";
    for (const auto& [id, why] : r.failed) std::cout << "  " << id << ": " << why << "\n";
    return kSomeFramesFailed;
  }
  return kOk;
}

}  // namespace terramrf::cli
