#include "support/test_paths.h"

namespace orpe::test {
const char* cli_path() {
  return ORPE_TEST_CLI_PATH;
}
const char* source_dir() {
  return ORPE_TEST_SOURCE_DIR;
}
}  // namespace orpe::test
