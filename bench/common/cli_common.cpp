#include "cli_common.hpp"

#include "machine.hpp"
#include "nnb/registry.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <vector>

namespace nnb::cli {

int run_reporting_errors(const std::string& program, const std::function<int()>& body) {
  try {
    return body();
  } catch (const InputError& e) {
    std::cerr << program << ": error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << program << ": internal error: " << e.what() << "\n";
    return 1;
  }
}

const char* const kDataDirHelp =
    "real scan folder (default: $NNB_DATA_DIR, else data/real in the clone, else ../shared/datasets/real "
    "beside it; scripts/fetch_data.sh fills data/real)";

std::string version_line(const std::string& program) {
  const std::string commit = nnb::bench::read_build_info().git_commit;
  return program + " " + NNB_VERSION + " (git " + (commit.empty() ? "unknown" : commit) + ", " + build_type() + ")";
}

std::optional<int> parse_command_line(CLI::App& app, int argc, char** argv, const std::string& program) {
  app.set_version_flag("--version", [program] { return version_line(program); },
                       "print the version, git commit and build type, and exit");
  try {
    app.parse(argc, argv);
    return std::nullopt;
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    std::string message = e.what();
    for (char& c : message) c = c == '\n' ? ' ' : c;
    std::cerr << program << ": error: " << message << " (see --help)\n";
    return 2;
  }
}

Params parse_params(const std::vector<std::string>& words) {
  Params params;
  for (const auto& word : words) {
    const auto eq = word.find('=');
    if (eq == std::string::npos || eq == 0) {
      throw InputError("parameter '" + word + "' is not of the form NAME=VALUE");
    }
    params[word.substr(0, eq)] = word.substr(eq + 1);
  }
  return params;
}

std::string build_type() {
  std::string type = NNB_BUILD_TYPE;
#ifdef NNB_SANITIZED
  type += "+sanitizers";
#endif
#ifndef NDEBUG
  type += "+assertions";
#endif
  return type;
}

bool is_release_build() {
#if defined(NDEBUG) && !defined(NNB_SANITIZED) && defined(__OPTIMIZE__)
  return true;
#else
  return false;
#endif
}

void warn_if_not_release(std::ostream& err) {
  if (!is_release_build()) {
    err << "WARNING: this is a " << build_type()
        << " build: its timings are not comparable; benchmark with the release preset\n";
  }
}

namespace {

// Every ranged strategy an adapter offers, the default first.
std::string ranged_strategy_list(const AdapterInfo& info) {
  std::string list;
  for (const Strategy s : info.strategies(SearchKind::ranged)) list += (list.empty() ? "" : ",") + std::string(to_string(s));
  return list;
}

}  // namespace

void print_adapter_list(std::ostream& out) {
  for (const auto& entry : adapter_registry()) {
    const auto index = entry.make({});
    const auto& info = index->info();
    out << info.name << "\t" << info.library << " " << info.version << "\t" << info.structure
        << "\tknn:" << to_string(info.knn) << " radius:" << to_string(info.radius)
        << " ranged:" << ranged_strategy_list(info) << (info.exact ? "" : "\tAPPROXIMATE") << "\n";
  }
}

}  // namespace nnb::cli
