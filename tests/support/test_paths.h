// Where the built CLI and the source tree are, for tests. Force-included into every test source
// (tests/CMakeLists.txt) so that ORPE_CLI_PATH / ORPE_SOURCE_DIR work in any test file.
//
// The absolute paths are compiled into one small file (test_paths.cpp) only: a macro holding an
// absolute path on every test file's command line would make each of them a ccache miss in every
// other checkout (worktrees, CI clones), so that a rebuild recompiled the whole suite.
#pragma once

namespace orpe::test {
/// The `orpe` binary of this build.
const char* cli_path();
/// The repository root of this build.
const char* source_dir();
}  // namespace orpe::test

#define ORPE_CLI_PATH ::orpe::test::cli_path()
#define ORPE_SOURCE_DIR ::orpe::test::source_dir()
