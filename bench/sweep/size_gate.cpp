#include "size_gate.hpp"

#include <algorithm>
#include <iomanip>
#include <sstream>

namespace nnb::sweep {
namespace {

constexpr double kGiB = 1024.0 * 1024.0 * 1024.0;

std::string gib_text(double bytes) {
  std::ostringstream out;
  out << std::setprecision(3) << bytes / kGiB << " GiB";
  return out.str();
}

std::string seconds_text(double s) {
  std::ostringstream out;
  out << std::setprecision(3) << s << " s";
  return out.str();
}

}  // namespace

SizeGate::SizeGate(double memory_limit_bytes, bool skip_larger_models, double budget_s)
    : limit_bytes_(memory_limit_bytes), by_size_(skip_larger_models), budget_s_(budget_s) {}

std::size_t SizeGate::build_memory_bytes(const Record& b) { return std::max(b.index_bytes, b.build_peak_rss_bytes); }

std::string SizeGate::reason_to_skip(const std::string& adapter, const std::string& model,
                                     std::size_t n_points) const {
  if (const auto it = closed_.find(adapter); it != closed_.end()) {
    const Closure& c = it->second;
    if (model != c.model && n_points >= c.n_points) {
      return "skipped on models of " + std::to_string(c.n_points) + " points and more: " + c.reason;
    }
  }
  // Linear extrapolation from the worst memory per point measured on the other models.
  const auto it = memory_.find(adapter);
  if (it == memory_.end()) return "";
  PerPoint worst;
  for (const auto& [measured_model, m] : it->second) {
    if (measured_model != model && m.bytes_per_point > worst.bytes_per_point) worst = m;
  }
  const double estimate = worst.bytes_per_point * static_cast<double>(n_points);
  if (worst.n_points == 0 || estimate <= limit_bytes_) return "";
  std::ostringstream out;
  out << std::setprecision(3) << "over memory limit: estimated " << gib_text(estimate) << " at " << n_points
      << " points (" << worst.bytes_per_point << " B/point measured at " << worst.n_points << " points) > "
      << gib_text(limit_bytes_);
  return out.str();
}

void SizeGate::judge_build(Record& b, double slowest_s) const {
  const std::string at = " at " + std::to_string(b.n_points) + " points";
  if (!b.skipped.empty()) {
    if (b.skipped.rfind("out of memory", 0) == 0) b.skips_larger = b.skipped;
    return;
  }
  const auto bytes = static_cast<double>(build_memory_bytes(b));
  if (bytes > limit_bytes_) {
    b.skips_larger = "over memory limit: " + gib_text(bytes) + at + " > " + gib_text(limit_bytes_);
  } else if (by_size_ && slowest_s > budget_s_) {
    b.skips_larger = "over budget: build " + seconds_text(slowest_s) + at + " > " + seconds_text(budget_s_);
  }
}

void SizeGate::judge_cell(Record& r, double fastest_s) const {
  if (r.skipped.rfind("out of memory", 0) == 0) r.skips_larger = r.skipped;
  if (!by_size_ || !r.skipped.empty() || fastest_s <= budget_s_) return;
  std::ostringstream out;
  out << "over budget: " << seconds_text(fastest_s) << " per call";
  if (r.max_dist_m) out << " at max_dist " << *r.max_dist_m;
  out << " at " << r.n_points << " points > " << seconds_text(budget_s_);
  r.skips_larger = out.str();
}

void SizeGate::observe(const Record& r) {
  if (r.type == Record::Type::build && r.skipped.empty() && r.n_points > 0) {
    memory_[r.adapter][r.model] = {static_cast<double>(build_memory_bytes(r)) / static_cast<double>(r.n_points),
                                   r.n_points};
  }
  if (r.skips_larger.empty()) return;
  const auto it = closed_.find(r.adapter);
  if (it == closed_.end() || r.n_points < it->second.n_points) {
    closed_[r.adapter] = {r.n_points, r.model, r.skips_larger};
  }
}

}  // namespace nnb::sweep
