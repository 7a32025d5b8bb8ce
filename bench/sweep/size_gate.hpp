#pragma once
// Which builds a run must not attempt, for the scale experiment and for the machine's sake: an adapter that
// ran out of memory, went over the memory limit or (skip_larger_models) over the time budget on a model is
// skipped on every other model at least as large; and a build whose memory, extrapolated linearly from the
// adapter's builds on other models, would pass the limit is skipped before it starts.
#include "record.hpp"

#include <cstddef>
#include <map>
#include <string>

namespace nnb::sweep {

class SizeGate {
 public:
  /// memory_limit_bytes: per build; skip_larger_models: the time budget closes larger models too.
  SizeGate(double memory_limit_bytes, bool skip_larger_models, double budget_s);

  /// Why the adapter must not be built on this model of n_points points; empty when it may.
  std::string reason_to_skip(const std::string& adapter, const std::string& model, std::size_t n_points) const;
  /// Sets b.skips_larger when a build ran out of memory, went over the memory limit, or (skip_larger_models)
  /// took longer than the budget; slowest_s: its slowest repetition, seconds.
  void judge_build(Record& b, double slowest_s) const;
  /// Sets r.skips_larger when a cell ran out of memory or (skip_larger_models) its fastest call took longer
  /// than the budget.
  void judge_cell(Record& r, double fastest_s) const;
  /// Learns from a record, new or resumed: the memory per point of a build, the closure a record carries.
  void observe(const Record& r);

  /// The memory a build is judged by: the larger of index_bytes and the peak RSS growth, bytes.
  static std::size_t build_memory_bytes(const Record& b);

 private:
  struct Closure {
    std::size_t n_points = 0;
    std::string model;
    std::string reason;
  };
  struct PerPoint {
    double bytes_per_point = 0.0;
    std::size_t n_points = 0;
  };
  double limit_bytes_;
  bool by_size_;
  double budget_s_;
  std::map<std::string, Closure> closed_;                                  // adapter -> smallest closing model
  std::map<std::string, std::map<std::string, PerPoint>> memory_;          // adapter -> model -> measured
};

}  // namespace nnb::sweep
