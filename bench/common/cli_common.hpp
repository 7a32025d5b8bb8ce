#pragma once
// What every command-line program here shares: the command line, error reporting, adapter listing.
#include "files.hpp"
#include "nnb/search_index.hpp"

#include <CLI/CLI.hpp>

#include <functional>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

namespace nnb::cli {

/// Runs body; an InputError becomes "<program>: error: <message>" and exit code 2, any other
/// exception exit code 1. Returns body's exit code otherwise.
int run_reporting_errors(const std::string& program, const std::function<int()>& body);

/// "PROG VERSION (git COMMIT, BUILD TYPE)": what --version prints.
std::string version_line(const std::string& program);
/// Adds the options every program shares (--version) and parses argv with the shared conventions:
/// --help and --version print and give 0; any other command-line error is the one line
/// "PROG: error: ..." and gives 2. Returns the exit code when the program should stop now.
std::optional<int> parse_command_line(CLI::App& app, int argc, char** argv, const std::string& program);
/// Help text of --data-dir, the same in every program.
extern const char* const kDataDirHelp;

/// Parses NAME=VALUE words into adapter parameters; throws InputError on a word without '='.
Params parse_params(const std::vector<std::string>& words);

/// The build type this binary was compiled as ("Release", "Debug", ...), "+sanitizers" appended if so.
std::string build_type();
/// True for an optimised build without sanitizers: the only kind whose timings mean anything.
bool is_release_build();
/// Prints a loud warning when timings come from a non-release build.
void warn_if_not_release(std::ostream& err);

/// Prints every adapter built in: name, library, version, structure and strategy per query kind.
void print_adapter_list(std::ostream& out);

}  // namespace nnb::cli
