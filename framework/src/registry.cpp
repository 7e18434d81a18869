#include "terramrf/registry.hpp"

#include <dlfcn.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <mutex>
#include <sstream>

namespace terramrf {
namespace fs = std::filesystem;

namespace {

// Folder of the library containing this function (libterramrf.so): plugins live beside it in
// terramrf/plugins, in the build tree as in the install tree.
std::string selfLibraryDir() {
  Dl_info info{};
  if (dladdr(reinterpret_cast<void*>(&selfLibraryDir), &info) && info.dli_fname) {
    return fs::path(info.dli_fname).parent_path().string();
  }
  return {};
}

using AbiFn = const char* (*)();
using DescFn = const PluginDescriptor* (*)();

struct Loaded {
  void* handle = nullptr;
  const PluginDescriptor* desc = nullptr;
};

bool debugLoading() {
  const char* v = std::getenv("TERRAMRF_PLUGIN_DEBUG");
  return v && *v && std::string(v) != "0";
}

// A static initialiser that throws cannot be caught through dlopen: the exception finds no
// handler past the loader's frames and std::terminate ends the process. The handler installed
// around dlopen names the library first, which is all that can be done then.
std::mutex g_load_mutex;  // one dlopen at a time: the handler and g_loading are process-wide
const char* g_loading = nullptr;
std::terminate_handler g_previous_terminate = nullptr;

[[noreturn]] void terminateWhileLoading() {
  std::string what;
  try {
    if (const std::exception_ptr e = std::current_exception()) std::rethrow_exception(e);
  } catch (const std::exception& e) {
    what = std::string(" threw: ") + e.what();
  } catch (...) {
    what = " threw an exception that is not a std::exception";
  }
  std::fprintf(stderr,
               "terramrf: ended while loading plugin library %s: its static initialisation%s. "
               "Remove the library from the plugin folders, or fix it: no exception may leave a "
               "plugin's static initialisers.\n",
               g_loading ? g_loading : "?", what.empty() ? " called std::terminate" : what.c_str());
  std::fflush(stderr);
  if (g_previous_terminate) g_previous_terminate();
  std::abort();
}

void* dlopenNamingOnTerminate(const std::string& path) {
  std::lock_guard<std::mutex> lock(g_load_mutex);
  if (debugLoading()) std::fprintf(stderr, "terramrf: loading plugin library %s\n", path.c_str());
  g_loading = path.c_str();
  g_previous_terminate = std::set_terminate(terminateWhileLoading);
  void* h = ::dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  std::set_terminate(g_previous_terminate);
  g_loading = nullptr;
  return h;
}

// What this build of the core is handed to plugins as; a plugin's descriptor must say the same.
const TypeLayout kCoreLayouts[] = {TERRAMRF_PLUGIN_LAYOUT_TYPES(TERRAMRF_PLUGIN_LAYOUT_ENTRY)};

// Empty if the plugin's compiler laid out the core types as the core's did; else what differs.
std::string layoutDifferences(const PluginDescriptor& d) {
  std::string diff;
  auto add = [&](const std::string& s) { diff += (diff.empty() ? "" : "; ") + s; };
  if (d.eigen_max_static_align_bytes != EIGEN_MAX_STATIC_ALIGN_BYTES)
    add("Eigen static alignment " + std::to_string(d.eigen_max_static_align_bytes) +
        " bytes in the plugin, " + std::to_string(EIGEN_MAX_STATIC_ALIGN_BYTES) + " in the core");
  for (const TypeLayout& core : kCoreLayouts) {
    const TypeLayout* mine = nullptr;
    for (std::size_t k = 0; d.layouts && k < d.layout_count; ++k)
      if (d.layouts[k].name && std::string(d.layouts[k].name) == core.name) mine = &d.layouts[k];
    if (!mine) {
      add(std::string(core.name) + " not measured by the plugin");
    } else if (mine->size_bytes != core.size_bytes || mine->align_bytes != core.align_bytes) {
      add(std::string(core.name) + " " + std::to_string(mine->size_bytes) + " bytes aligned to " +
          std::to_string(mine->align_bytes) + " in the plugin, " + std::to_string(core.size_bytes) +
          " aligned to " + std::to_string(core.align_bytes) + " in the core");
    }
  }
  return diff;
}

// Everything the core reads of a descriptor, checked before it is used: a hand-written or
// damaged one would otherwise crash the loader or escape as an exception naming no file.
void checkDescriptor(const std::string& path, const PluginDescriptor* d) {
  auto refuse = [&](const std::string& why) { throw PluginLoadError(path + ": " + why); };
  if (!d) refuse("terramrf_plugin_descriptor() returned no descriptor (null)");
  const int kind = static_cast<int>(d->kind);
  if (kind < static_cast<int>(PluginKind::kSource) || kind > static_cast<int>(PluginKind::kOutput))
    refuse("descriptor kind " + std::to_string(kind) +
           " is not a plugin kind (expected 0 to 5: source, egomotion, feature, energy, "
           "optimiser, output)");
  if (!d->type || !*d->type) refuse("descriptor has no type name (null or empty)");
  if (!d->summary) refuse("descriptor of '" + std::string(d->type) + "' has no summary (null)");
  if (!d->create)
    refuse("descriptor of '" + std::string(d->type) + "' has no create function (null)");
  const std::string diff = layoutDifferences(*d);
  if (!diff.empty())
    refuse(
        "built with other compiler flags than this TerraMRF, so the core's types are laid out "
        "differently (" +
        diff +
        "); build the plugin with the same compiler flags as TerraMRF (e.g. the same -m/-march "
        "options)");
}

// Libraries stay loaded for the life of the process: instances' vtables live in them.
Loaded openPlugin(const std::string& path) {
  void* h = dlopenNamingOnTerminate(path);
  if (!h) {
    const char* e = ::dlerror();
    throw PluginLoadError(path + ": not a loadable shared library (" + (e ? e : "?") + ")");
  }
  auto abi = reinterpret_cast<AbiFn>(::dlsym(h, "terramrf_plugin_abi"));
  auto desc = reinterpret_cast<DescFn>(::dlsym(h, "terramrf_plugin_descriptor"));
  if (!abi || !desc) {
    ::dlclose(h);
    throw PluginLoadError(path +
                          ": not a TerraMRF plugin (no terramrf_plugin_abi/terramrf_plugin_descriptor"
                          " symbol; was it built with TERRAMRF_PLUGIN(...)?)");
  }
  // Copied before dlclose: the text lives in the library's own memory, unmapped with it.
  const char* abi_text = abi();
  const std::string got = abi_text ? abi_text : "(null)";
  if (!abi_text || got != TERRAMRF_ABI_STRING) {
    ::dlclose(h);
    throw PluginLoadError(path + ": built against '" + got + "', but this is '" +
                          TERRAMRF_ABI_STRING + "'; rebuild the plugin against this version");
  }
  const PluginDescriptor* d = desc();
  try {
    checkDescriptor(path, d);
  } catch (...) {
    ::dlclose(h);
    throw;
  }
  return {h, d};
}

// The base class each kind is used as (config.cpp, the sweeps and the CLI static_cast to it).
bool isOfKind(Plugin* p, PluginKind kind) {
  switch (kind) {
    case PluginKind::kSource:
      return dynamic_cast<Source*>(p) != nullptr;
    case PluginKind::kOutput:
      return dynamic_cast<Output*>(p) != nullptr;
    default:
      return dynamic_cast<Stage*>(p) != nullptr;
  }
}

}  // namespace

PluginRegistry::PluginRegistry(std::vector<std::string> dirs) : dirs_(std::move(dirs)) { scan(); }

std::vector<std::string> PluginRegistry::defaultSearchDirs() {
  std::vector<std::string> dirs;
  const std::string lib = selfLibraryDir();
  if (!lib.empty()) dirs.push_back((fs::path(lib) / "terramrf" / "plugins").string());
  if (const char* env = std::getenv("TERRAMRF_PLUGIN_PATH")) {
    std::stringstream ss(env);
    std::string d;
    while (std::getline(ss, d, ':'))
      if (!d.empty()) dirs.push_back(d);
  }
  return dirs;
}

void PluginRegistry::prependDirs(const std::vector<std::string>& dirs) {
  dirs_.insert(dirs_.begin(), dirs.begin(), dirs.end());
  scan();
}

PluginInfo PluginRegistry::inspect(const std::string& path) {
  Loaded l = openPlugin(path);
  return {l.desc->type, l.desc->kind, l.desc->summary, path};
}

void PluginRegistry::scan() {
  by_type_.clear();
  problems_.clear();
  for (const auto& dir : dirs_) {
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) {
      problems_.push_back(dir + ": plugin folder " +
                          (fs::exists(dir, ec) ? "is not a folder" : "does not exist") +
                          " (skipped)");
      continue;
    }
    std::vector<fs::path> files;
    for (auto it = fs::directory_iterator(dir, ec); !ec && it != fs::directory_iterator();
         it.increment(ec))
      if (it->path().extension() == ".so") files.push_back(it->path());
    if (ec) problems_.push_back(dir + ": cannot list the plugin folder (" + ec.message() + ")");
    std::sort(files.begin(), files.end());
    for (const auto& f : files) {
      try {
        PluginInfo info = inspect(f.string());
        auto it = by_type_.find(info.type);
        if (it != by_type_.end()) {
          if (fs::equivalent(it->second.library, f, ec)) continue;
          problems_.push_back(f.string() + ": plugin type '" + info.type +
                              "' already provided by " + it->second.library + " (ignored)");
          continue;
        }
        by_type_.emplace(info.type, info);
      } catch (const PluginLoadError& e) {
        problems_.push_back(e.what());
      } catch (const std::exception& e) {  // from the plugin's own functions
        problems_.push_back(f.string() + ": " + e.what());
      }
    }
  }
}

std::vector<PluginInfo> PluginRegistry::list() const {
  std::vector<PluginInfo> v;
  for (const auto& kv : by_type_) v.push_back(kv.second);
  std::stable_sort(v.begin(), v.end(), [](const PluginInfo& a, const PluginInfo& b) {
    return static_cast<int>(a.kind) < static_cast<int>(b.kind);
  });
  return v;
}

const PluginInfo* PluginRegistry::find(const std::string& type) const {
  auto it = by_type_.find(type);
  return it == by_type_.end() ? nullptr : &it->second;
}

std::vector<std::string> PluginRegistry::types() const {
  std::vector<std::string> t;
  for (const auto& kv : by_type_) t.push_back(kv.first);
  return t;
}

std::unique_ptr<Plugin> PluginRegistry::create(const std::string& type) const {
  const PluginInfo* info = find(type);
  if (!info) {
    std::string where;
    for (const auto& d : dirs_) where += (where.empty() ? "" : ", ") + d;
    throw PluginLoadError("unknown plugin type '" + type + "' (searched: " + where + ")");
  }
  Loaded l = openPlugin(info->library);  // dlopen is reference-counted: cheap after the scan
  std::unique_ptr<Plugin> p;
  try {
    p.reset(l.desc->create());
  } catch (const std::exception& e) {
    throw PluginLoadError(info->library + ": creating a '" + type + "' threw: " + e.what());
  }
  if (!p)
    throw PluginLoadError(info->library + ": creating a '" + type + "' returned no object (null)");
  // A descriptor the TERRAMRF_PLUGIN macro did not check at compile time can name the wrong
  // kind; the callers cast to the kind's base class without looking.
  if (!isOfKind(p.get(), l.desc->kind))
    throw PluginLoadError(info->library + ": '" + type + "' is declared a " +
                          toString(l.desc->kind) + " plugin, but its class does not derive from " +
                          (l.desc->kind == PluginKind::kSource   ? "terramrf::Source"
                           : l.desc->kind == PluginKind::kOutput ? "terramrf::Output"
                                                                 : "terramrf::Stage") +
                          "; fix the kind in its TERRAMRF_PLUGIN(...) line");
  p->setIdentity(type, type);
  return p;
}

}  // namespace terramrf
