// ThreadSanitizer sees only instrumented code: our trees, brute force, the header-only nanoflann and ITK's
// k-d tree (class templates), compiled into the test with the API that splits a batch over threads. The
// libraries shipped compiled are checked by the same test without it (their answers on threads against one
// thread).
#include "subjects.hpp"

namespace nnb::adapters {
std::unique_ptr<SearchIndex> make_brute_force(const Params& params);
std::unique_ptr<SearchIndex> make_ours_kdtree(const Params& params);
std::unique_ptr<SearchIndex> make_ours_octree(const Params& params);
std::unique_ptr<SearchIndex> make_nanoflann_kdtree(const Params& params);
std::unique_ptr<SearchIndex> make_simple_kdtree(const Params& params);
std::unique_ptr<SearchIndex> make_sfc_morton(const Params& params);
#ifdef NNB_TSAN_WITH_ITK
std::unique_ptr<SearchIndex> make_itk_kdtree(const Params& params);
#endif
}  // namespace nnb::adapters

namespace nnb::testing {

std::vector<ThreadSubject> thread_subjects() {
  using namespace nnb::adapters;
  std::vector<ThreadSubject> subjects{{"brute_force", make_brute_force, {}},
                                      {"ours_kdtree", make_ours_kdtree, {}},
                                      {"ours_octree", make_ours_octree, {}},
                                      {"nanoflann_kdtree", make_nanoflann_kdtree, {}},
                                      {"simple_kdtree", make_simple_kdtree, {}},
                                      {"sfc_morton", make_sfc_morton, {}}};
#ifdef NNB_TSAN_WITH_ITK
  subjects.push_back({"itk_kdtree", make_itk_kdtree, {}});
#endif
  add_variants(subjects);
  return subjects;
}

}  // namespace nnb::testing
