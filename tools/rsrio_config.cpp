// rsrio-config FILE: validates an options file as every rsrio program would and prints the
// resolved values with the quantities derived from them. Exit 0 when valid, 2 when not.
#include <iostream>

#include "rsrio/common/cli.hpp"
#include "rsrio/common/options.hpp"
#include "rsrio/common/radar_config.hpp"

int main(int argc, char** argv) {
  std::string file;
  rsrio::Cli cli("rsrio-config", "Validate an rsrio options file (YAML) and print the resolved values.");
  cli.positional("FILE", "the options file to check (same as --config FILE)", &file, false);
  if (auto rc = cli.parse(argc, argv)) return *rc;
  if (file.empty()) file = cli.config_path();
  if (file.empty()) return cli.usage_error("missing FILE");
  try {
    rsrio::OptionsFile options(file);
    rsrio::OptionsNode root = options.root();
    std::string log_level = "info";
    root.read_choice("log_level", log_level, {"trace", "debug", "info", "warn", "error", "critical", "off"});
    rsrio::OptionsNode radar_node = root.child("radar", true);
    const rsrio::RadarConfig radar = rsrio::load_radar_config(radar_node);
    root.finish();
    std::cout << "# " << file << ": valid\n";
    std::cout << "log_level: " << log_level << "\n";
    rsrio::print(std::cout, radar);
  } catch (const rsrio::ConfigError& e) {
    std::cerr << "rsrio-config: error: " << e.what() << "\n";
    return rsrio::kExitUsage;
  }
  return 0;
}
