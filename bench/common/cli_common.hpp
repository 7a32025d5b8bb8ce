#pragma once
// What every command-line program here shares: error reporting, adapter listing, safe file writing.
#include "nnb/search_index.hpp"

#include <functional>
#include <ostream>
#include <string>
#include <vector>

namespace nnb::cli {

/// Runs body; an InputError becomes "<program>: error: <message>" and exit code 2, any other
/// exception exit code 1. Returns body's exit code otherwise.
int run_reporting_errors(const std::string& program, const std::function<int()>& body);

/// Parses NAME=VALUE words into adapter parameters; throws InputError on a word without '='.
Params parse_params(const std::vector<std::string>& words);

/// Writes text to path through a temporary file in the same directory and a rename, so a reader never
/// sees a half-written file; throws InputError when the directory is not writable.
void write_file_atomically(const std::string& path, const std::string& text);

/// The build type this binary was compiled as ("Release", "Debug", ...), "+sanitizers" appended if so.
std::string build_type();
/// True for an optimised build without sanitizers: the only kind whose timings mean anything.
bool is_release_build();
/// Prints a loud warning when timings come from a non-release build.
void warn_if_not_release(std::ostream& err);

/// Prints every adapter built in: name, library, version, structure and strategy per query kind.
void print_adapter_list(std::ostream& out);
/// The paper's Table 1 regenerated from the adapters' declared data, as Markdown.
std::string table1_markdown();

}  // namespace nnb::cli
