#include "orpe/nets/plugin.h"

#include <dlfcn.h>

#include <filesystem>
#include <mutex>
#include <vector>

#include "orpe/core/error.h"

// Set on this file only (CMakeLists.txt): ORPE_NETS_WITH_TORCH, ORPE_NETS_PLUGIN_NAME,
// ORPE_NETS_INSTALL_LIBDIR (relative), ORPE_NETS_PLUGIN_INSTALLED and ORPE_NETS_PLUGIN_BUILT
// (absolute paths).
#ifndef ORPE_NETS_WITH_TORCH
#define ORPE_NETS_WITH_TORCH 0
#endif

namespace orpe::nets {

bool torch_built() {
  return ORPE_NETS_WITH_TORCH != 0;
}

#if ORPE_NETS_WITH_TORCH
namespace {

std::vector<std::string> plugin_candidates() {
  std::vector<std::string> paths;
  if (const char* env = std::getenv("ORPE_NETS_PLUGIN"); env && *env) return {env};
  std::error_code ec;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const auto up = exe.parent_path().parent_path();
    paths.push_back((up / "lib" / ORPE_NETS_PLUGIN_NAME).string());
    paths.push_back((up / ORPE_NETS_INSTALL_LIBDIR / ORPE_NETS_PLUGIN_NAME).string());
  }
  paths.push_back(ORPE_NETS_PLUGIN_INSTALLED);
  paths.push_back(ORPE_NETS_PLUGIN_BUILT);
  return paths;
}

const PluginApi* load_plugin(std::string* why) {
  for (const std::string& path : plugin_candidates()) {
    if (!std::filesystem::is_regular_file(path)) {
      *why += "\n  " + path + ": no such file";
      continue;
    }
    void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!handle) {
      *why += "\n  " + path + ": " + dlerror();
      continue;
    }
    using Entry = const PluginApi* (*)();
    const auto entry = reinterpret_cast<Entry>(dlsym(handle, "orpe_nets_plugin"));
    const PluginApi* api = entry ? entry() : nullptr;
    if (api && api->version == kPluginApiVersion) return api;  // kept open for the process
    *why += "\n  " + path + ": not an orpe nets plugin of this version";
    dlclose(handle);
  }
  return nullptr;
}

}  // namespace
#endif

const PluginApi& nets_plugin(const std::string& what) {
#if ORPE_NETS_WITH_TORCH
  static std::once_flag once;
  static const PluginApi* api = nullptr;
  static std::string why;
  std::call_once(once, [] { api = load_plugin(&why); });
  if (!api)
    throw ConfigError(what + ": cannot load the LibTorch plugin " + ORPE_NETS_PLUGIN_NAME +
                      " (set ORPE_NETS_PLUGIN to its path):" + why);
  return *api;
#else
  throw ConfigError(what +
                    ": orpe was built without LibTorch (ORPE_WITH_TORCH=OFF); install "
                    "libtorch-dev (scripts/install-deps.sh) and rebuild (docs/NETWORKS.md)");
#endif
}

std::map<std::string, HostTensor> read_tensor_file(const std::string& path) {
  return nets_plugin("reading " + path).read_tensor_file(path);
}

MaskRcnnNetwork::MaskRcnnNetwork(const std::string& model_path, const MaskRcnnOptions& options)
    : impl_(nets_plugin("segmentation.backend=maskrcnn (" + model_path + ")")
                .open_maskrcnn(model_path, options)) {}

MaskRcnnNetwork::~MaskRcnnNetwork() = default;

int MaskRcnnNetwork::num_classes() const {
  return impl_->num_classes();
}

MaskRcnnOutput MaskRcnnNetwork::run(const ColorImage& image) const {
  return impl_->run(image);
}

}  // namespace orpe::nets

namespace orpe::nets {

DenseFusionNetwork::DenseFusionNetwork(const DenseFusionSpec& spec)
    : impl_(nets_plugin("densefusion").open_densefusion(spec)) {}

DenseFusionNetwork::~DenseFusionNetwork() = default;

DenseFusionPoints DenseFusionNetwork::estimate(const std::vector<float>& crop_chw, int h, int w,
                                               const std::vector<float>& cloud,
                                               const std::vector<std::int64_t>& choose,
                                               int obj) const {
  return impl_->estimate(crop_chw, h, w, cloud, choose, obj);
}

DenseFusionPose DenseFusionNetwork::pose(const DenseFusionPoints& points,
                                         const std::vector<float>& cloud, int obj, int iterations,
                                         DenseFusionPose* before_refinement) const {
  return impl_->pose(points, cloud, obj, iterations, before_refinement);
}

int DenseFusionNetwork::num_objects() const {
  return impl_->num_objects();
}
int DenseFusionNetwork::num_points() const {
  return impl_->num_points();
}
bool DenseFusionNetwork::has_refiner() const {
  return impl_->has_refiner();
}

std::vector<std::pair<std::string, std::vector<std::int64_t>>> DenseFusionNetwork::parameters()
    const {
  return impl_->parameters();
}

}  // namespace orpe::nets
