// The command-line rules every program shares: parsing, its exit codes, and the exit code and
// message for an exception that ends a program (report_program_error).
#include "rsrio/common/cli.hpp"

#include <iostream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <catch2/catch_test_macros.hpp>

#include "rsrio/common/options.hpp"

namespace {

// Captures what is written on one standard stream for the duration of a scope. Only around the
// call itself for std::cout: Catch2 reports failed checks there.
struct Captured {
  std::ostream& stream;
  std::ostringstream text;
  std::streambuf* old = stream.rdbuf(text.rdbuf());
  explicit Captured(std::ostream& s) : stream(s) {}
  ~Captured() { stream.rdbuf(old); }
  std::string str() const { return text.str(); }
};

std::optional<int> parse(rsrio::Cli& cli, std::vector<const char*> args) {
  args.insert(args.begin(), "prog");
  return cli.parse(static_cast<int>(args.size()), args.data());
}

template <typename E>
int report(const E& e) {
  try {
    throw e;
  } catch (...) {
    return rsrio::report_program_error("prog", std::current_exception());
  }
}

}  // namespace

TEST_CASE("Cli: options, switches and positionals; bad command lines exit 2 with a hint") {
  std::string input, out;
  bool quiet = false;
  rsrio::Cli cli("prog", "a test program");
  cli.option("--out", "DIR", "where", &out).flag("--quiet", "less", &quiet).positional("INPUT", "what", &input);

  Captured err(std::cerr);
  CHECK_FALSE(parse(cli, {"--out", "a", "--quiet", "in.mcap"}).has_value());
  CHECK(out == "a");
  CHECK(quiet);
  CHECK(input == "in.mcap");
  CHECK_FALSE(parse(cli, {"--out=b", "x", "--log-level", "debug"}).has_value());
  CHECK(out == "b");
  CHECK(cli.log_level() == "debug");

  std::optional<int> help_rc;
  std::string help_text;
  {
    Captured help_out(std::cout);
    help_rc = parse(cli, {"--help"});
    help_text = help_out.str();
  }
  CHECK(help_rc == 0);
  CHECK(help_text.find("usage: prog [options] INPUT") != std::string::npos);
  CHECK(parse(cli, {"--bogus", "x"}) == rsrio::kExitUsage);
  CHECK(err.str().find("prog: error: unknown option --bogus\n(see prog --help)") != std::string::npos);
  CHECK(parse(cli, {"x", "--out"}) == rsrio::kExitUsage);
  CHECK(err.str().find("--out needs a value (DIR)") != std::string::npos);
  CHECK(parse(cli, {"--quiet=1", "x"}) == rsrio::kExitUsage);
  CHECK(parse(cli, {}) == rsrio::kExitUsage);
  CHECK(err.str().find("missing INPUT") != std::string::npos);
  CHECK(parse(cli, {"x", "y"}) == rsrio::kExitUsage);
  CHECK(err.str().find("unexpected argument 'y'") != std::string::npos);
}

TEST_CASE("report_program_error: a bad option exits 2, any other failure 1, each with its message") {
  Captured err(std::cerr);
  CHECK(report(rsrio::ConfigError("run.yaml", "backend.lr_means", "a number in (0, 1]")) == rsrio::kExitUsage);
  CHECK(err.str().rfind("prog: error: run.yaml", 0) == 0);
  CHECK(err.str().find("backend.lr_means") != std::string::npos);

  err.text.str("");
  CHECK(report(std::runtime_error("in.mcap: truncated chunk at byte 4096")) == 1);
  CHECK(err.str() == "prog: error: in.mcap: truncated chunk at byte 4096\n");

  err.text.str("");
  CHECK(report(42) == 1);
  CHECK(err.str() == "prog: error: unknown exception\n");
}
