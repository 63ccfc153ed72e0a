#include "orpe/core/openmp_waits.h"

#include <unistd.h>

#include <cstdlib>
#include <cstring>

namespace orpe {

void prefer_passive_openmp_waits(char** argv) {
  if (std::getenv("OMP_WAIT_POLICY") != nullptr || std::getenv("GOMP_SPINCOUNT") != nullptr) return;
  const char* preload = std::getenv("LD_PRELOAD");
  if (preload != nullptr && std::strstr(preload, "vgpreload") != nullptr) return;
  if (setenv("OMP_WAIT_POLICY", "passive", 1) != 0) return;
  execv("/proc/self/exe", argv);  // returns only when it failed
  unsetenv("OMP_WAIT_POLICY");
}

}  // namespace orpe
