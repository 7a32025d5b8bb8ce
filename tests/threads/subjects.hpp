#pragma once
// The adapters the threaded tests run: every one built in (subjects_registry.cpp), or under ThreadSanitizer
// the ones whose code it can see, compiled into the test itself (subjects_tsan.cpp).
#include "nnb/registry.hpp"

#include <ostream>
#include <string>
#include <vector>

namespace nnb::testing {

struct ThreadSubject {
  std::string name;
  AdapterFactory make;
  Params params;  ///< the adapter's parameters: a variant of an adapter is a subject of its own

  std::unique_ptr<SearchIndex> create() const { return make(params); }
};

/// Variants worth their own subject: ours answering every batch in Morton order, which a small random
/// batch on a small tree does not always choose (the threaded slicing then follows that order too), and
/// ours answering hinted batches from its neighbour graph, which the first of the threads makes.
inline void add_variants(std::vector<ThreadSubject>& subjects) {
  const std::size_t n = subjects.size();
  for (std::size_t i = 0; i < n; ++i) {
    if (subjects[i].name.rfind("ours_", 0) == 0) {
      subjects.push_back({subjects[i].name + "_order_morton", subjects[i].make, {{"order", "morton"}}});
      subjects.push_back({subjects[i].name + "_hints_graph", subjects[i].make, {{"hints", "graph"}}});
    }
  }
}

std::vector<ThreadSubject> thread_subjects();

/// Test names print the adapter's name.
inline void PrintTo(const ThreadSubject& subject, std::ostream* os) { *os << subject.name; }

}  // namespace nnb::testing
