// Stand-in for src/orpe/nets/torch when orpe is built without LibTorch (ORPE_WITH_TORCH=OFF): the
// network back-ends exist in the configuration but say that they were not built.
#include "orpe/core/error.h"
#include "orpe/nets/maskrcnn.h"

namespace orpe::nets {

namespace {
[[noreturn]] void not_built(const std::string& what) {
  throw ConfigError(what +
                    ": orpe was built without LibTorch (ORPE_WITH_TORCH=OFF); install "
                    "libtorch-dev (scripts/install-deps.sh) and rebuild (docs/NETWORKS.md)");
}
}  // namespace

bool torch_built() {
  return false;
}

std::map<std::string, HostTensor> read_tensor_file(const std::string& path) {
  not_built("reading " + path);
}

struct MaskRcnnNetwork::Impl {};

MaskRcnnNetwork::MaskRcnnNetwork(const std::string& model_path, const MaskRcnnOptions& options) {
  (void)options;
  not_built("segmentation.backend=maskrcnn (" + model_path + ")");
}
MaskRcnnNetwork::~MaskRcnnNetwork() = default;
int MaskRcnnNetwork::num_classes() const {
  return 0;
}
MaskRcnnOutput MaskRcnnNetwork::run(const ColorImage& image) const {
  (void)image;
  not_built("segmentation.backend=maskrcnn");
}

}  // namespace orpe::nets
