// Embedding orpe in a program of one's own (docs/EMBEDDING.md): frames in one at a time, the map's
// objects and their fused poses read after each frame.
//   orpe_consumer DATASET_DIR   prints one line per frame and the final objects; exit 0 when at
//                               least one object has a fused pose.
#include <cstdio>
#include <exception>

#include "orpe/core/version.h"
#include "orpe/io/dataset.h"
#include "orpe/pipeline/config.h"
#include "orpe/pipeline/object_rpe.h"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: orpe_consumer DATASET_DIR\n");
    return 2;
  }
  // Deliberately unused: this file is compiled without warnings as errors. If the project's
  // -Wall -Werror leaked through orpe::orpe, this line would fail the consumer's build.
  int unused_on_purpose = 0;
  try {
    orpe::OrpeConfig config;  // defaults; a user would load a file or set fields here
    auto reader = orpe::open_dataset(argv[1], config.dataset);
    orpe::ObjectRpePipeline pipeline(orpe::ObjectRpeParams::from_config(config), reader->info());
    for (size_t i = 0; i < reader->size(); ++i) {
      const orpe::PipelineFrameResult& r = pipeline.process(reader->read(i));
      std::printf("frame %d: %s\n", r.frame_index, r.report().c_str());
    }
    pipeline.finalize();
    int with_pose = 0;
    for (const orpe::ObjectWorldPose& o : pipeline.object_poses(0)) {
      const auto t = o.T_world_obj.translation();
      std::printf("object %d %s: pose %s, t_world = (%.3f, %.3f, %.3f) m, %d views\n",
                  o.instance_id, o.class_name.c_str(), o.valid ? "valid" : "none", t.x(), t.y(),
                  t.z(), o.num_views);
      with_pose += o.valid ? 1 : 0;
    }
    std::printf("orpe %s: %d objects with a fused pose\n", orpe::kVersion, with_pose);
    return with_pose > 0 ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
