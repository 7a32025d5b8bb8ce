#include "answer_size.hpp"

#include <algorithm>

namespace nnb {

std::optional<std::size_t> radius_answer_past_limit(const SearchIndex& index, const Cloud& queries,
                                                    double radius_m, std::size_t limit) {
  const std::size_t n_model = index.model_size();
  const double most = static_cast<double>(queries.cols()) * static_cast<double>(n_model);
  if (n_model == 0 || most <= static_cast<double>(limit)) return std::nullopt;
  const auto slice = static_cast<Eigen::Index>(std::max<std::size_t>(1, limit / n_model));
  std::size_t total = 0;
  Neighbours found;
  for (Eigen::Index first = 0; first < queries.cols(); first += slice) {
    index.radius(queries.middleCols(first, std::min(slice, queries.cols() - first)), radius_m, found);
    total += found.total();
    if (total > limit) return total;
  }
  return std::nullopt;
}

}  // namespace nnb
