#pragma once
// Comparing one adapter's answer with brute force's, by distance (ties make correct libraries return
// different indices), with a failure message that prints both neighbour lists.
#include "nnb/registry.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>
#include <string>

namespace nnb::testing {

/// Tolerance on squared distances (m^2), relative to max(1, sq): adapters refine float results in double,
/// so exact adapters agree with brute force to the last bits; 1e-9 leaves room for summation order only.
inline double sq_tolerance(double sq_m2) { return 1e-9 * std::max(1.0, sq_m2); }

inline std::string row_text(const Neighbours& n, std::size_t q) {
  std::ostringstream text;
  text.precision(17);
  for (std::size_t i = n.offsets[q]; i < n.offsets[q + 1]; ++i) {
    text << " (" << n.indices[i] << ", " << std::sqrt(n.sq_dists[i]) << " m)";
  }
  return n.count(q) == 0 ? std::string(" (none)") : text.str();
}

/// Checks got against expected for every query: same counts, same sorted distances, distances that match
/// the returned indices, no duplicate index, rows sorted when sorted_rows. Returns failure text or "".
inline std::string compare_with_reference(const Cloud& model, const Cloud& queries, const Neighbours& expected,
                                          const Neighbours& got, bool sorted_rows) {
  if (got.n_queries() != expected.n_queries()) {
    return "result has " + std::to_string(got.n_queries()) + " queries, expected " +
           std::to_string(expected.n_queries());
  }
  std::vector<double> a, b;
  for (std::size_t q = 0; q < expected.n_queries(); ++q) {
    std::string problem;
    std::set<PointIndex> seen;
    const double* query = queries.col(static_cast<Eigen::Index>(q)).data();
    for (std::size_t i = got.offsets[q]; i < got.offsets[q + 1] && problem.empty(); ++i) {
      if (got.indices[i] >= static_cast<PointIndex>(model.cols())) problem = "index out of range";
      else if (!seen.insert(got.indices[i]).second) problem = "duplicate index " + std::to_string(got.indices[i]);
      else if (std::abs(got.sq_dists[i] - sq_dist_m2(query, model.col(got.indices[i]).data())) >
               sq_tolerance(got.sq_dists[i])) {
        problem = "distance does not match its index " + std::to_string(got.indices[i]);
      } else if (sorted_rows && i > got.offsets[q] && got.sq_dists[i] < got.sq_dists[i - 1]) {
        problem = "row not sorted nearest first";
      }
    }
    if (problem.empty() && got.count(q) != expected.count(q)) {
      problem = "found " + std::to_string(got.count(q)) + " neighbours, expected " + std::to_string(expected.count(q));
    }
    if (problem.empty()) {
      a.assign(expected.sq_dists.begin() + static_cast<std::ptrdiff_t>(expected.offsets[q]),
               expected.sq_dists.begin() + static_cast<std::ptrdiff_t>(expected.offsets[q + 1]));
      b.assign(got.sq_dists.begin() + static_cast<std::ptrdiff_t>(got.offsets[q]),
               got.sq_dists.begin() + static_cast<std::ptrdiff_t>(got.offsets[q + 1]));
      std::sort(a.begin(), a.end());
      std::sort(b.begin(), b.end());
      for (std::size_t i = 0; i < a.size() && problem.empty(); ++i) {
        if (std::abs(a[i] - b[i]) > sq_tolerance(a[i])) problem = "distance #" + std::to_string(i) + " differs";
      }
    }
    if (!problem.empty()) {
      std::ostringstream msg;
      msg.precision(17);
      msg << "query " << q << " (" << query[0] << ", " << query[1] << ", " << query[2] << "): " << problem
          << "\n  brute force:" << row_text(expected, q) << "\n  adapter:    " << row_text(got, q);
      return msg.str();
    }
  }
  return "";
}

}  // namespace nnb::testing
