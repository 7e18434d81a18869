#include "terramrf/registry.hpp"

#include <dlfcn.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
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

// Libraries stay loaded for the life of the process: instances' vtables live in them.
Loaded openPlugin(const std::string& path) {
  void* h = ::dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
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
  const std::string got = abi();
  if (got != TERRAMRF_ABI_STRING) {
    ::dlclose(h);
    throw PluginLoadError(path + ": built against '" + got + "', but this is '" +
                          TERRAMRF_ABI_STRING + "'; rebuild the plugin against this version");
  }
  return {h, desc()};
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
    if (!fs::is_directory(dir, ec)) continue;
    std::vector<fs::path> files;
    for (const auto& e : fs::directory_iterator(dir, ec))
      if (e.path().extension() == ".so") files.push_back(e.path());
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
  std::unique_ptr<Plugin> p(l.desc->create());
  p->setIdentity(type, type);
  return p;
}

}  // namespace terramrf
