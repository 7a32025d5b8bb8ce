#pragma once
// This process's memory, from Linux's /proc/self: what a build took, for the memory limit; and the output
// memory a timed call writes into.
#include "nnb/neighbours.hpp"
#include "nnb/search_index.hpp"

#include <cstddef>

namespace nnb::sweep {

/// Resident set size of this process now (VmRSS), bytes; 0 when /proc/self/status is unreadable.
std::size_t current_rss_bytes();
/// Peak resident set size (VmHWM) since the start or the last reset_peak_rss(), bytes; 0 when unknown.
std::size_t peak_rss_bytes();
/// Resets the peak to the current RSS (writes "5" to /proc/self/clear_refs); false when the kernel refuses.
bool reset_peak_rss();

/// Empties out with room for n_queries rows and n_neighbours answers, every byte of that room written once,
/// so that a call answering within it faults in no fresh page.
void touch_output(std::size_t n_queries, std::size_t n_neighbours, Neighbours& out);

/// The answers a timed call gets room for. A k-NN call's count is known: k_per_query (k, at most the points) a
/// query. A radius or ranged call's is not, so it follows what is known of it: the count of its cell's earlier
/// round, else of the call before it; a ranged call's at least one a query and at most k_per_query a query,
/// lest a large k write gigabytes before a small answer.
std::size_t output_room(SearchKind kind, std::size_t k_per_query, std::size_t n_queries, std::size_t earlier_count,
                        std::size_t last_count);

/// A timed call into out, which touch_output gave room for room answers: returns what call() returns (its
/// times). A call whose answers outgrew the room (a radius search's first round: nothing told its count)
/// faulted in fresh pages of out as it wrote them, the harness's cost and not the library's, which can be
/// several times the call's own where page faults are dear, and can end a series over the time budget: that
/// call is made again, its answers now within written memory, and only the second counts. room grows to the
/// answers either way.
template <class Call>
auto call_within_room(Call&& call, const Neighbours& out, std::size_t& room) {
  auto times = call();
  if (out.total() > room) {
    room = out.total();
    times = call();
  }
  return times;
}

}  // namespace nnb::sweep
