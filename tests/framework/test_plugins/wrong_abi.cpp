// A library that looks like a plugin but was "built against another version".
#include "terramrf/plugin.hpp"

extern "C" __attribute__((visibility("default"))) const char* terramrf_plugin_abi() {
  return "terramrf 0.0.1 cxx11abi=1";
}
extern "C" __attribute__((visibility("default"))) const terramrf::PluginDescriptor*
terramrf_plugin_descriptor() {
  return nullptr;
}
