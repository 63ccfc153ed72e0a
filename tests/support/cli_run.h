// Tests that run the `orpe` CLI (real-data end-to-end tests): the command, and the JSON it writes.
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

namespace orpe::test {

/// The JSON file at `path`; an empty object (and a test failure naming the path) if unreadable.
inline nlohmann::json read_json(const std::string& path) {
  std::ifstream is(path);
  EXPECT_TRUE(is.good()) << path;
  if (!is.good()) return nlohmann::json::object();
  return nlohmann::json::parse(is);
}

/// Runs `orpe -q ARGS` (a shell command line: redirections allowed); returns system()'s status.
inline int run_cli(const std::string& args) {
  const std::string cmd = std::string("OMP_WAIT_POLICY=passive ") + ORPE_CLI_PATH + " -q " + args;
  return std::system(cmd.c_str());
}

}  // namespace orpe::test
