#include "cli_common.hpp"

#include "nnb/registry.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <sstream>

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

void write_file_atomically(const std::string& path, const std::string& text) {
  namespace fs = std::filesystem;
  const fs::path target(path);
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::error_code ec;
  fs::create_directories(dir, ec);
  const fs::path temp = dir / ("." + target.filename().string() + ".tmp." + std::to_string(::getpid()));
  std::FILE* file = std::fopen(temp.c_str(), "wb");
  if (file == nullptr) throw InputError("cannot write " + temp.string() + ": " + std::strerror(errno));
  const bool written = std::fwrite(text.data(), 1, text.size(), file) == text.size();
  const bool flushed = std::fflush(file) == 0 && ::fsync(::fileno(file)) == 0;
  const bool closed = std::fclose(file) == 0;
  if (!written || !flushed || !closed) {
    fs::remove(temp, ec);
    throw InputError("cannot write " + temp.string() + ": " + std::strerror(errno));
  }
  fs::rename(temp, target, ec);
  if (ec) {
    fs::remove(temp, ec);
    throw InputError("cannot replace " + path + ": " + ec.message());
  }
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

void print_adapter_list(std::ostream& out) {
  for (const auto& entry : adapter_registry()) {
    const auto index = entry.make({});
    const auto& info = index->info();
    out << info.name << "\t" << info.library << " " << info.version << "\t" << info.structure
        << "\tknn:" << to_string(info.knn) << " radius:" << to_string(info.radius)
        << " ranged:" << to_string(info.ranged) << (info.exact ? "" : "\tAPPROXIMATE") << "\n";
  }
}

namespace {

std::string table_cell(Strategy strategy) {
  switch (strategy) {
    case Strategy::native: return "native";
    case Strategy::via_knn: return "via k-NN";
    case Strategy::via_radius: return "via radius";
    case Strategy::via_box: return "via box + filter";
    case Strategy::unsupported: return "no";
  }
  return "?";
}

}  // namespace

std::string table1_markdown() {
  std::ostringstream md;
  md << "| adapter | library | version | data structure | precision | k-NN | fixed radius | ranged | parameters |\n"
     << "|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& entry : adapter_registry()) {
    const auto index = entry.make({});
    const auto& info = index->info();
    std::string params;
    for (const auto& [name, value] : info.params) params += (params.empty() ? "" : ", ") + name + "=" + value;
    md << "| " << info.name << " | " << info.library << " | " << info.version << " | " << info.structure
       << (info.exact ? "" : " (approximate)") << " | " << info.scalar << " | " << table_cell(info.knn) << " | "
       << table_cell(info.radius) << " | " << table_cell(info.ranged) << " | " << params << " |\n";
  }
  return md.str();
}

}  // namespace nnb::cli
