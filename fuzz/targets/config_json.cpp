// Config files (pipeline/config.h load_config_file, `orpe run --config`) and `--set` overrides:
// part 1 = the config file, read both as config.json and as config.yaml (yaml-cpp); optional part
// 2 = one "section.key=value" override per line. The result is then validated (IsValid) as the CLI
// does.
#include <string>

#include "orpe/core/error.h"
#include "orpe/pipeline/config.h"
#include "support/fuzz_support.h"

namespace {

void load_and_validate(const std::string& path, const std::vector<std::string_view>& parts) {
  using namespace orpe::fuzz;
  expect_clean_refusal([&] {
    orpe::OrpeConfig config;
    orpe::load_config_file(config, path);
    if (parts.size() > 1) {
      std::string_view rest = parts[1];
      while (!rest.empty()) {
        const size_t eol = rest.find('\n');
        orpe::apply_config_override(config, std::string(rest.substr(0, eol)));
        rest.remove_prefix(eol == std::string_view::npos ? rest.size() : eol + 1);
      }
    }
    std::string why;
    (void)config.IsValid(&why);
  });
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace orpe::fuzz;
  static const std::string json_path = scratch_path("config.json");
  static const std::string yaml_path = scratch_path("config.yaml");
  const auto parts = split_parts(data, size, 2);
  write_file(json_path, parts[0]);
  write_file(yaml_path, parts[0]);
  for (const std::string* path : {&json_path, &yaml_path}) load_and_validate(*path, parts);
  return 0;
}
