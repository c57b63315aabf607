// The command-line rules every rsrio program follows: --help, --version, --config FILE (YAML,
// validated before anything starts), --log-level LEVEL. Programs declare their own options on top.
//
// Exit codes: 0 after --help / --version, 2 for a bad command line or a bad configuration.
#pragma once

#include <exception>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace rsrio {

inline constexpr int kExitUsage = 2;

class Cli {
 public:
  Cli(std::string program, std::string summary);

  /// --name VALUE (stored as a string; convert and check in the program).
  Cli& option(std::string name, std::string metavar, std::string help, std::string* value);
  /// --name, a switch.
  Cli& flag(std::string name, std::string help, bool* value);
  /// Positional arguments, in order; `required` ones must be given.
  Cli& positional(std::string metavar, std::string help, std::string* value, bool required = true);

  /// Parses argv. Prints help/version and returns an exit code (0) when the program should stop;
  /// prints the error with a usage hint and returns kExitUsage on a bad command line; returns
  /// std::nullopt when the program should go on.
  std::optional<int> parse(int argc, const char* const* argv);

  /// The values of the common options.
  const std::string& config_path() const { return config_path_; }
  const std::string& log_level() const { return log_level_; }

  std::string help() const;

  /// For a bad command line found after parse(): prints "PROGRAM: error: MESSAGE" and the hint to
  /// --help on stderr, returns kExitUsage.
  int usage_error(const std::string& message) const;

 private:
  struct Opt {
    std::string name, metavar, help;
    std::string* value = nullptr;
    bool* flag = nullptr;
  };
  struct Pos {
    std::string metavar, help;
    std::string* value;
    bool required;
  };
  std::string program_, summary_;
  std::vector<Opt> options_;
  std::vector<Pos> positionals_;
  std::string config_path_;
  std::string log_level_;
};

/// The project's version string ("rsrio 0.1.0 (git abc1234)").
std::string version_string();

}  // namespace rsrio

namespace rsrio {

class OptionsNode;

/// The general rule for every program's `--config FILE`: opens the YAML file, lets `read` take the
/// sections this program knows, rejects every key nobody read, then applies `log_level` (top-level
/// key, overridden by --log-level) and sets up logging. Without --config, `read` is not called and
/// the defaults stand. On a bad file prints "PROGRAM: error: FILE: key 'K': expected ..." and
/// returns kExitUsage; std::nullopt when the program should go on.
std::optional<int> load_program_config(const Cli& cli, const std::string& program,
                                       const std::function<void(OptionsNode&)>& read);

/// What a program's main() returns for an exception that ended it, after printing
/// "PROGRAM: error: WHAT" on stderr: kExitUsage for a ConfigError (an option found bad only once
/// the program ran, e.g. a recording's radar section), 1 for anything else. A program whose work
/// runs in one try block ends it with
/// `catch (...) { return report_program_error(kProgram, std::current_exception()); }`.
int report_program_error(const std::string& program, const std::exception_ptr& error);

}  // namespace rsrio
