#pragma once
// This process's memory, from Linux's /proc/self: what a build took, for the memory limit.
#include <cstddef>

namespace nnb::sweep {

/// Resident set size of this process now (VmRSS), bytes; 0 when /proc/self/status is unreadable.
std::size_t current_rss_bytes();
/// Peak resident set size (VmHWM) since the start or the last reset_peak_rss(), bytes; 0 when unknown.
std::size_t peak_rss_bytes();
/// Resets the peak to the current RSS (writes "5" to /proc/self/clear_refs); false when the kernel refuses.
bool reset_peak_rss();

}  // namespace nnb::sweep
