#include "subjects.hpp"

namespace nnb::testing {

std::vector<ThreadSubject> thread_subjects() {
  std::vector<ThreadSubject> subjects;
  for (const AdapterEntry& entry : adapter_registry()) subjects.push_back({entry.name, entry.make, {}});
  add_variants(subjects);
  return subjects;
}

}  // namespace nnb::testing
