// The LibTorch plugin of the nets stage: src/orpe/nets/torch is built into a shared module,
// liborpe_nets_torch.so, that the stage opens (dlopen) the first time a network is asked for. So
// only a process that runs a network loads LibTorch (~1 s of start-up and ~100 MB), and the orpe
// binary runs without LibTorch installed when no network back-end is chosen. Internal to the stage.
#pragma once

#include <map>
#include <memory>
#include <string>

#include "orpe/nets/densefusion.h"
#include "orpe/nets/maskrcnn.h"

namespace orpe::nets {

/// A loaded Mask R-CNN (the plugin's side of MaskRcnnNetwork).
class MaskRcnnImpl {
 public:
  virtual ~MaskRcnnImpl() = default;
  virtual int num_classes() const = 0;
  virtual MaskRcnnOutput run(const ColorImage& image) const = 0;
};

/// A loaded DenseFusion (the plugin's side of DenseFusionNetwork).
class DenseFusionImpl {
 public:
  virtual ~DenseFusionImpl() = default;
  virtual DenseFusionPoints estimate(const std::vector<float>& crop_chw, int h, int w,
                                     const std::vector<float>& cloud,
                                     const std::vector<std::int64_t>& choose, int obj) const = 0;
  virtual DenseFusionPose pose(const DenseFusionPoints& points, const std::vector<float>& cloud,
                               int obj, int iterations, DenseFusionPose* before) const = 0;
  virtual std::vector<std::pair<std::string, std::vector<std::int64_t>>> parameters() const = 0;
  virtual int num_objects() const = 0;
  virtual int num_points() const = 0;
  virtual bool has_refiner() const = 0;
};

/// What the plugin exports, through `extern "C" const PluginApi* orpe_nets_plugin()`.
struct PluginApi {
  int version = 0;  ///< kPluginApiVersion of the plugin's build
  std::unique_ptr<MaskRcnnImpl> (*open_maskrcnn)(const std::string& path,
                                                 const MaskRcnnOptions& options) = nullptr;
  std::map<std::string, HostTensor> (*read_tensor_file)(const std::string& path) = nullptr;
  std::unique_ptr<DenseFusionImpl> (*open_densefusion)(const DenseFusionSpec& spec) = nullptr;
};

inline constexpr int kPluginApiVersion = 3;

/// The plugin, opened on first use. Throws ConfigError saying why when orpe was built without
/// LibTorch or the plugin cannot be loaded (the paths tried, dlerror()). `what` names the caller in
/// the message. Search: $ORPE_NETS_PLUGIN, <exe dir>/../lib, <exe dir>/../<libdir>, the install
/// libdir, the build tree.
const PluginApi& nets_plugin(const std::string& what);

}  // namespace orpe::nets
