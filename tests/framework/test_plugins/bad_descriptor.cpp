// Libraries whose descriptor lies or is damaged, one defect each (TERRAMRF_TEST_DEFECT), as a
// hand-written or older descriptor could: the loader must refuse each naming the file, not crash.
#include <cstring>

#include "terramrf/plugin.hpp"

namespace {

class AnOutput final : public terramrf::Output {
 public:
  void write(const terramrf::FrameContext&) override {}
};

terramrf::Plugin* makeOutput() { return new AnOutput(); }
terramrf::Plugin* makeNothing() { return nullptr; }

const terramrf::TypeLayout kLayouts[] = {
    TERRAMRF_PLUGIN_LAYOUT_TYPES(TERRAMRF_PLUGIN_LAYOUT_ENTRY)};

terramrf::PluginDescriptor descriptor() {
  terramrf::PluginDescriptor d{
      terramrf::PluginKind::kOutput,         "test_bad_" TERRAMRF_TEST_DEFECT,
      "test-only damaged descriptor",        makeOutput,
      EIGEN_MAX_STATIC_ALIGN_BYTES,          kLayouts,
      sizeof(kLayouts) / sizeof(kLayouts[0])};
  const std::string defect = TERRAMRF_TEST_DEFECT;
  if (defect == "null_type") d.type = nullptr;
  if (defect == "empty_type") d.type = "";
  if (defect == "null_summary") d.summary = nullptr;
  if (defect == "null_create") d.create = nullptr;
  if (defect == "create_returns_null") d.create = makeNothing;
  if (defect == "bad_kind") d.kind = static_cast<terramrf::PluginKind>(9);
  // An output declared a source: the macro refuses this at compile time, a hand-written
  // descriptor cannot be stopped before it is loaded.
  if (defect == "wrong_kind") d.kind = terramrf::PluginKind::kSource;
  return d;
}

}  // namespace

extern "C" __attribute__((visibility("default"))) const char* terramrf_plugin_abi() {
  return TERRAMRF_ABI_STRING;
}
extern "C" __attribute__((visibility("default"))) const terramrf::PluginDescriptor*
terramrf_plugin_descriptor() {
  static const terramrf::PluginDescriptor d = descriptor();
  return std::strcmp(TERRAMRF_TEST_DEFECT, "null_descriptor") == 0 ? nullptr : &d;
}
