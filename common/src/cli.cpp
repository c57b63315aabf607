#include "rsrio/common/cli.hpp"

#include <iostream>
#include <sstream>

#include "rsrio/common/version.hpp"

namespace rsrio {

std::string version_string() {
  return std::string("rsrio ") + kVersion + " (git " + kGitRevision + ")";
}

Cli::Cli(std::string program, std::string summary)
    : program_(std::move(program)), summary_(std::move(summary)) {
  option("--config", "FILE", "YAML options file (cv::FileStorage), validated before anything starts",
         &config_path_);
  option("--log-level", "LEVEL", "trace, debug, info, warn, error, critical or off (overrides the file)",
         &log_level_);
}

Cli& Cli::option(std::string name, std::string metavar, std::string help, std::string* value) {
  options_.push_back({std::move(name), std::move(metavar), std::move(help), value, nullptr});
  return *this;
}

Cli& Cli::flag(std::string name, std::string help, bool* value) {
  options_.push_back({std::move(name), "", std::move(help), nullptr, value});
  return *this;
}

Cli& Cli::positional(std::string metavar, std::string help, std::string* value, bool required) {
  positionals_.push_back({std::move(metavar), std::move(help), value, required});
  return *this;
}

std::string Cli::help() const {
  std::ostringstream s;
  s << "usage: " << program_ << " [options]";
  for (const auto& p : positionals_) s << (p.required ? " " : " [") << p.metavar << (p.required ? "" : "]");
  s << "\n\n" << summary_ << "\n\n";
  for (const auto& p : positionals_) s << "  " << p.metavar << "\n      " << p.help << "\n";
  for (const auto& o : options_)
    s << "  " << o.name << (o.metavar.empty() ? "" : " " + o.metavar) << "\n      " << o.help << "\n";
  s << "  --help\n      print this help and exit\n  --version\n      print the version and exit\n";
  return s.str();
}

int Cli::usage_error(const std::string& message) const {
  std::cerr << program_ << ": error: " << message << "\n(see " << program_ << " --help)\n";
  return kExitUsage;
}

std::optional<int> Cli::parse(int argc, const char* const* argv) {
  std::size_t next_pos = 0;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::cout << help();
      return 0;
    }
    if (a == "--version") {
      std::cout << program_ << " " << version_string() << "\n";
      return 0;
    }
    if (a.rfind("--", 0) == 0) {
      std::string value;
      bool has_inline = false;
      if (const auto eq = a.find('='); eq != std::string::npos) {
        value = a.substr(eq + 1);
        a = a.substr(0, eq);
        has_inline = true;
      }
      const Opt* match = nullptr;
      for (const auto& o : options_)
        if (o.name == a) match = &o;
      if (!match) return usage_error("unknown option " + a);
      if (match->flag) {
        if (has_inline) return usage_error(a + " takes no value");
        *match->flag = true;
        continue;
      }
      if (!has_inline) {
        if (i + 1 >= argc) return usage_error(a + " needs a value (" + match->metavar + ")");
        value = argv[++i];
      }
      *match->value = value;
      continue;
    }
    if (next_pos >= positionals_.size()) return usage_error("unexpected argument '" + a + "'");
    *positionals_[next_pos++].value = a;
  }
  for (std::size_t p = next_pos; p < positionals_.size(); ++p)
    if (positionals_[p].required) return usage_error("missing " + positionals_[p].metavar);
  return std::nullopt;
}

}  // namespace rsrio

#include "rsrio/common/log.hpp"
#include "rsrio/common/options.hpp"

namespace rsrio {

std::optional<int> load_program_config(const Cli& cli, const std::string& program,
                                       const std::function<void(OptionsNode&)>& read) {
  std::string level = "info";
  try {
    if (!cli.config_path().empty()) {
      OptionsFile file(cli.config_path());
      OptionsNode root = file.root();
      root.read_choice("log_level", level, {"trace", "debug", "info", "warn", "error", "critical", "off"});
      read(root);
      root.finish();
    }
  } catch (const ConfigError& e) {
    std::cerr << program << ": error: " << e.what() << "\n";
    return kExitUsage;
  }
  if (!cli.log_level().empty()) {
    if (!is_log_level(cli.log_level())) {
      std::cerr << program << ": error: --log-level: expected one of trace debug info warn error critical off, got '"
                << cli.log_level() << "'\n";
      return kExitUsage;
    }
    level = cli.log_level();
  }
  setup_logging(program, level);
  return std::nullopt;
}

int report_program_error(const std::string& program, const std::exception_ptr& error) {
  try {
    std::rethrow_exception(error);
  } catch (const ConfigError& e) {
    std::cerr << program << ": error: " << e.what() << "\n";
    return kExitUsage;
  } catch (const std::exception& e) {
    std::cerr << program << ": error: " << e.what() << "\n";
  } catch (...) {
    std::cerr << program << ": error: unknown exception\n";
  }
  return 1;
}

}  // namespace rsrio
