#pragma once
// A unit of work (one index, its cells) in a child process, so that a library that crashes or hangs
// costs its own cells, not the sweep: the child sends each checkpoint batch back through a pipe.
#include "record.hpp"
#include "runner.hpp"

#include <functional>
#include <string>
#include <vector>

namespace nnb::sweep {

/// Runs body in a forked child; every batch the child adds to its sink arrives through on_batch in this
/// process, in order. The child's sink answers find() from `known` as it was at the fork. Returns why the
/// child failed ("crashed: ..." for a signal or a non-zero exit, "timed out: ..." when no batch arrived for
/// timeout_s seconds, after which it is killed), empty when it finished. On SIGINT or SIGTERM the child is
/// stopped and "interrupted" is returned.
std::string run_in_child(const ResultsSink& known, const std::function<void(ResultsSink&)>& body,
                         const std::function<void(const std::vector<Record>&)>& on_batch, double timeout_s);

/// True for a record of a cell whose child crashed or timed out (what --retry-failed runs again).
bool is_failure(const Record& r);

}  // namespace nnb::sweep
