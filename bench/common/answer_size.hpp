#pragma once
// The size of a radius search's answer, counted before anyone holds it whole: a budget on neighbours
// (nns_query's --max-neighbours, run_sweep's neighbour_budget) judged before the search it protects.
#include "nnb/search_index.hpp"

#include <cstddef>
#include <optional>

namespace nnb {

/// Counts the neighbours radius search of queries at radius_m finds, in slices of queries that cannot
/// together find more than limit (one query at least), and stops once the count passes limit. Returns
/// that count (a lower bound on the whole answer) when it does, nothing when the whole answer fits.
std::optional<std::size_t> radius_answer_past_limit(const SearchIndex& index, const Cloud& queries,
                                                    double radius_m, std::size_t limit);

}  // namespace nnb
