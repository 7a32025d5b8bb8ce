#include "cli_common.hpp"

#include "machine.hpp"
#include "nnb/registry.hpp"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <utility>
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

// Every ranged strategy an adapter offers, the default first, each written by text().
template <class Text>
std::string strategy_list(const AdapterInfo& info, const char* separator, Text text) {
  std::string list;
  for (const Strategy s : info.strategies(SearchKind::ranged)) list += (list.empty() ? "" : separator) + std::string(text(s));
  return list;
}

}  // namespace

void print_adapter_list(std::ostream& out) {
  for (const auto& entry : adapter_registry()) {
    const auto index = entry.make({});
    const auto& info = index->info();
    out << info.name << "\t" << info.library << " " << info.version << "\t" << info.structure
        << "\tknn:" << to_string(info.knn) << " radius:" << to_string(info.radius)
        << " ranged:" << strategy_list(info, ",", [](Strategy s) { return to_string(s); }) << (info.exact ? "" : "\tAPPROXIMATE") << "\n";
  }
}

namespace {

// The display text of a strategy; plots/style.py's STRATEGY_TEXT holds the same words.
std::string table_cell(Strategy strategy) {
  switch (strategy) {
    case Strategy::native: return "native";
    case Strategy::native_unpruned: return "native, unpruned";
    case Strategy::via_knn: return "via k-NN";
    case Strategy::via_radius: return "via radius";
    case Strategy::via_box: return "via box";
    case Strategy::unsupported: return "no";
  }
  return "?";
}

// The library's own ranged calls are in bold, as plots/table1.py writes them.
std::string ranged_cell(Strategy strategy) {
  const bool own = strategy == Strategy::native || strategy == Strategy::native_unpruned;
  return own ? "**" + table_cell(strategy) + "**" : table_cell(strategy);
}

std::string escaped(std::string text) {
  for (std::size_t at = text.find('|'); at != std::string::npos; at = text.find('|', at + 2)) text.insert(at, "\\");
  return text;
}

}  // namespace

// The same table as plots/table1.py makes from a results file (tests/test_run_sweep.py checks they agree).
std::string table1_markdown() {
  std::ostringstream md;
  md << "| adapter | library | version | data structure | precision | k-NN | fixed radius | ranged | exact | parameters |\n"
     << "|---|---|---|---|---|---|---|---|---|---|\n";
  std::vector<std::pair<std::string, AdapterInfo>> rows;
  for (const auto& entry : adapter_registry()) rows.emplace_back(entry.name, entry.make({})->info());
  std::sort(rows.begin(), rows.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  for (const auto& [name, info] : rows) {
    std::string params;
    for (const auto& [key, value] : info.params) params += (params.empty() ? "" : ", ") + key + "=" + value;
    const std::vector<std::string> cells{info.name, info.library, info.version, info.structure, info.scalar,
                                         table_cell(info.knn), table_cell(info.radius),
                                         strategy_list(info, "; ", ranged_cell),
                                         info.exact ? "yes" : "**no (approximate)**", params.empty() ? "-" : params};
    md << "|";
    for (const auto& cell : cells) md << " " << escaped(cell) << " |";
    md << "\n";
  }
  return md.str();
}

}  // namespace nnb::cli
