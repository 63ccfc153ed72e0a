// The version of the orpe library and CLI. The single source of truth: CMakeLists.txt reads
// ORPE_VERSION_STRING from this file for project(VERSION), the package version file and install.
#pragma once

#define ORPE_VERSION_STRING "0.1.0"

namespace orpe {
/// "MAJOR.MINOR.PATCH" of this build (`orpe --version`, summary.json "orpe_version").
inline constexpr const char* kVersion = ORPE_VERSION_STRING;
}  // namespace orpe
