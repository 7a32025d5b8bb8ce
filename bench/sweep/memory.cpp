#include "memory.hpp"

#include <algorithm>
#include <fstream>
#include <sstream>
#include <string>

namespace nnb::sweep {
namespace {

// A "Key:   1234 kB" line of /proc/self/status, in bytes.
std::size_t status_kib_field(const std::string& key) {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.compare(0, key.size() + 1, key + ":") != 0) continue;
    std::istringstream fields(line.substr(key.size() + 1));
    std::size_t kib = 0;
    fields >> kib;
    return kib * 1024;
  }
  return 0;
}

}  // namespace

std::size_t current_rss_bytes() { return status_kib_field("VmRSS"); }

std::size_t peak_rss_bytes() { return status_kib_field("VmHWM"); }

bool reset_peak_rss() {
  std::ofstream out("/proc/self/clear_refs");
  out << "5";
  out.flush();
  return static_cast<bool>(out);
}

void touch_output(std::size_t n_queries, std::size_t n_neighbours, Neighbours& out) {
  out.offsets.assign(n_queries + 1, 0);
  out.indices.assign(n_neighbours, 0);
  out.sq_dists.assign(n_neighbours, 0.0);
  out.reset();
}

std::size_t output_room(SearchKind kind, std::size_t k_per_query, std::size_t n_queries, std::size_t earlier_count,
                        std::size_t last_count) {
  const std::size_t known = std::max(earlier_count, last_count);
  switch (kind) {
    case SearchKind::knn: return k_per_query * n_queries;
    case SearchKind::radius: return known;
    case SearchKind::ranged: return std::min(k_per_query * n_queries, std::max(known, n_queries));
  }
  return known;
}

}  // namespace nnb::sweep
