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
};

std::vector<ThreadSubject> thread_subjects();

/// Test names print the adapter's name.
inline void PrintTo(const ThreadSubject& subject, std::ostream* os) { *os << subject.name; }

}  // namespace nnb::testing
