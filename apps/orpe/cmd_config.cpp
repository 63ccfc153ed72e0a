// `orpe config`: prints the effective configuration with each key's documentation.
#include <fmt/format.h>

#include <iostream>

#include "command.h"

namespace orpe::cli {
namespace {

struct ConfigCommand {
  ConfigOptions options;
  bool json = false;
};

CommandRegistrar reg(90, [](CLI::App& root) {
  auto state = std::make_shared<ConfigCommand>();
  CLI::App* app = root.add_subcommand("config", "Print the effective configuration and its documentation");
  add_config_options(*app, state->options);
  app->add_flag("--json", state->json, "Print as a JSON config file (loadable with --config)");
  app->callback([state] {
    const OrpeConfig config = resolve_config(state->options);
    if (state->json) {
      std::cout << config_to_json(config) << "\n";
      return;
    }
    for (const auto& d : describe_config(config))
      std::cout << fmt::format("{:<34} = {:<12} [{}]  {}\n", d.key, d.value, d.type, d.doc);
  });
});

}  // namespace
}  // namespace orpe::cli
