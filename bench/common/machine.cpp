#include "machine.hpp"

#include "nnb_build_commit.hpp"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <sstream>

namespace nnb::bench {
namespace {

// Where /sys and /proc are read from: NNB_MACHINE_ROOT lets a test stand for a machine that exposes nothing.
std::string machine_path(const std::string& path) {
  const char* root = std::getenv("NNB_MACHINE_ROOT");
  return root ? root + path : path;
}

std::string read_line(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  return line;
}

long parse_size(const std::string& text) {  // "32K", "1024K", "32768K", "8M"
  if (text.empty()) return 0;
  long value = std::atol(text.c_str());
  switch (text.back()) {
    case 'K': value *= 1024; break;
    case 'M': value *= 1024 * 1024; break;
    case 'G': value *= 1024L * 1024 * 1024; break;
    default: break;
  }
  return value;
}

int count_cpus(const std::string& list) {  // "0-1,4"
  int n = 0;
  std::stringstream stream(list);
  std::string range;
  while (std::getline(stream, range, ',')) {
    const auto dash = range.find('-');
    if (dash == std::string::npos) ++n;
    else n += std::atoi(range.c_str() + dash + 1) - std::atoi(range.c_str()) + 1;
  }
  return n;
}

// The caches of cpu0 as the kernel lists them; virtual machines and some arm64 kernels list none.
std::vector<CacheInfo> read_sys_caches() {
  std::vector<CacheInfo> caches;
  for (int i = 0;; ++i) {
    const std::string dir = machine_path("/sys/devices/system/cpu/cpu0/cache/index") + std::to_string(i) + "/";
    const std::string type = read_line(dir + "type");
    if (type.empty()) break;
    caches.push_back({type, std::atoi(read_line(dir + "level").c_str()), parse_size(read_line(dir + "size")),
                      count_cpus(read_line(dir + "shared_cpu_list"))});
  }
  return caches;
}

// x86's /proc/cpuinfo names one cache ("cache size : 512 KB", level unknown); elsewhere there is none.
std::vector<CacheInfo> read_cpuinfo_cache() {
  std::ifstream cpuinfo(machine_path("/proc/cpuinfo"));
  for (std::string line; std::getline(cpuinfo, line);) {
    if (line.rfind("cache size", 0) != 0) continue;
    std::string size = line.substr(line.find(':') + 1);
    size.erase(std::remove(size.begin(), size.end(), ' '), size.end());  // "512KB"
    if (size.size() > 1 && size.back() == 'B') size.pop_back();
    const long bytes = parse_size(size);
    if (bytes > 0) return {{"Unified", 0, bytes, 0}};
    break;
  }
  return {};
}

std::vector<double> load_average() {
  double load[3];
  if (getloadavg(load, 3) != 3) return {};
  return {load[0], load[1], load[2]};
}

struct RunStart {
  std::time_t wall = std::time(nullptr);
  std::chrono::steady_clock::time_point steady = std::chrono::steady_clock::now();
  std::vector<double> load_avg = load_average();
  std::string command_line;
};

RunStart& run_start() {
  static RunStart start;
  return start;
}

std::string shell_quoted(const std::string& word) {
  std::string quoted = "'";
  for (char c : word) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

}  // namespace

void mark_run_start(int argc, char** argv) {
  RunStart& start = run_start();
  start = RunStart{};
  for (int i = 0; i < argc; ++i) start.command_line += (i ? " " : "") + shell_quoted(argv[i]);
}

RunInfo read_run_info() {
  const RunStart& start = run_start();
  return {start.command_line, std::chrono::duration<double>(std::chrono::steady_clock::now() - start.steady).count(),
          load_average()};
}

MachineInfo read_machine_info() {
  MachineInfo m;
  const std::time_t now = run_start().wall;
  char date[64];
  std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%S%z", std::localtime(&now));
  m.date = date;
  char host[256] = {};
  if (gethostname(host, sizeof host - 1) == 0) m.host_name = host;
  m.num_cpus = static_cast<int>(sysconf(_SC_NPROCESSORS_ONLN));
  std::ifstream cpuinfo(machine_path("/proc/cpuinfo"));
  for (std::string line; std::getline(cpuinfo, line);) {
    if (line.rfind("cpu MHz", 0) == 0) {
      m.mhz_per_cpu = std::atof(line.c_str() + line.find(':') + 1);
      break;
    }
  }
  const std::string governor = read_line(machine_path("/sys/devices/system/cpu/cpu0/cpufreq/scaling_governor"));
  m.cpu_scaling_enabled = !governor.empty() && governor != "performance";
  m.caches = read_sys_caches();
  if (m.caches.empty()) m.caches = read_cpuinfo_cache();
  // The load when the run started: a file written at the end must not report its own run's load as "before".
  m.load_avg = run_start().load_avg;
  return m;
}

BuildInfo read_build_info() {
  BuildInfo b;
  b.compiler = NNB_MACHINE_COMPILER;
  b.flags = NNB_MACHINE_FLAGS;
  b.build_type = NNB_MACHINE_BUILD_TYPE;
  b.source_dir = NNB_MACHINE_SOURCE_DIR;
#ifdef NDEBUG
  b.ndebug = true;
#endif
#if defined(__SANITIZE_ADDRESS__) || defined(NNB_MACHINE_SANITIZE)
  b.sanitizers = true;
#endif
  // Stamped at every build: a binary kept from an older build names the code it runs, not today's tree.
  b.git_commit = NNB_BUILD_GIT_COMMIT;
  return b;
}

}  // namespace nnb::bench
