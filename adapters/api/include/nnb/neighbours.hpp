#pragma once
// The result of a batch search, in compressed rows: the neighbours of query q are the entries
// [offsets[q], offsets[q+1]) of indices and sq_dists.
#include "nnb/cloud.hpp"

#include <cstddef>
#include <vector>

namespace nnb {

struct Neighbours {
  std::vector<std::size_t> offsets{0};  ///< n_queries + 1 entries, offsets[0] == 0
  std::vector<PointIndex> indices;      ///< indices into the model cloud
  std::vector<double> sq_dists;         ///< squared distances, square metres

  /// Number of queries the result holds.
  std::size_t n_queries() const { return offsets.size() - 1; }
  /// Number of neighbours found for query q.
  std::size_t count(std::size_t q) const { return offsets[q + 1] - offsets[q]; }
  /// Total number of neighbours found over all queries.
  std::size_t total() const { return indices.size(); }
  /// Number of queries that found at least one neighbour.
  std::size_t queries_with_neighbours() const {
    std::size_t n = 0;
    for (std::size_t q = 0; q < n_queries(); ++q) n += count(q) > 0;
    return n;
  }

  /// Empties the result, keeping its memory, ready for push() and end_query().
  void reset(std::size_t expected_queries = 0, std::size_t expected_neighbours = 0) {
    offsets.clear();
    offsets.push_back(0);
    indices.clear();
    sq_dists.clear();
    offsets.reserve(expected_queries + 1);
    indices.reserve(expected_neighbours);
    sq_dists.reserve(expected_neighbours);
  }
  /// Appends one neighbour to the query being filled.
  void push(PointIndex index, double sq_dist_m2) {
    indices.push_back(index);
    sq_dists.push_back(sq_dist_m2);
  }
  /// Closes the query being filled.
  void end_query() { offsets.push_back(indices.size()); }
};

}  // namespace nnb
