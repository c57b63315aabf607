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

// Captures what a call writes on std::cerr (and std::cout) for the duration of a scope.
struct CapturedStreams {
  std::ostringstream err, out;
  std::streambuf* old_err = std::cerr.rdbuf(err.rdbuf());
  std::streambuf* old_out = std::cout.rdbuf(out.rdbuf());
  ~CapturedStreams() {
    std::cerr.rdbuf(old_err);
    std::cout.rdbuf(old_out);
  }
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
  std::string input, out, level;
  bool quiet = false;
  rsrio::Cli cli("prog", "a test program");
  cli.option("--out", "DIR", "where", &out).flag("--quiet", "less", &quiet).positional("INPUT", "what", &input);

  CapturedStreams streams;
  CHECK_FALSE(parse(cli, {"--out", "a", "--quiet", "in.mcap"}).has_value());
  CHECK(out == "a");
  CHECK(quiet);
  CHECK(input == "in.mcap");
  CHECK_FALSE(parse(cli, {"--out=b", "x", "--log-level", "debug"}).has_value());
  CHECK(out == "b");
  CHECK(cli.log_level() == "debug");

  CHECK(parse(cli, {"--help"}) == 0);
  CHECK(streams.out.str().find("usage: prog [options] INPUT") != std::string::npos);
  CHECK(parse(cli, {"--bogus", "x"}) == rsrio::kExitUsage);
  CHECK(streams.err.str().find("prog: error: unknown option --bogus\n(see prog --help)") != std::string::npos);
  CHECK(parse(cli, {"x", "--out"}) == rsrio::kExitUsage);
  CHECK(streams.err.str().find("--out needs a value (DIR)") != std::string::npos);
  CHECK(parse(cli, {"--quiet=1", "x"}) == rsrio::kExitUsage);
  CHECK(parse(cli, {}) == rsrio::kExitUsage);
  CHECK(streams.err.str().find("missing INPUT") != std::string::npos);
  CHECK(parse(cli, {"x", "y"}) == rsrio::kExitUsage);
  CHECK(streams.err.str().find("unexpected argument 'y'") != std::string::npos);
}

TEST_CASE("report_program_error: a bad option exits 2, any other failure 1, each with its message") {
  CapturedStreams streams;
  CHECK(report(rsrio::ConfigError("run.yaml", "backend.lr_means", "a number in (0, 1]")) == rsrio::kExitUsage);
  CHECK(streams.err.str().rfind("prog: error: run.yaml", 0) == 0);
  CHECK(streams.err.str().find("backend.lr_means") != std::string::npos);

  streams.err.str("");
  CHECK(report(std::runtime_error("in.mcap: truncated chunk at byte 4096")) == 1);
  CHECK(streams.err.str() == "prog: error: in.mcap: truncated chunk at byte 4096\n");

  streams.err.str("");
  CHECK(report(42) == 1);
  CHECK(streams.err.str() == "prog: error: unknown exception\n");
}
