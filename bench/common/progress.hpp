#pragma once
// Progress on stderr: a redrawn bar with the current cell and an ETA on a terminal, plain lines otherwise.
#include <chrono>
#include <cstddef>
#include <string>

namespace nnb::bench {

class Progress {
 public:
  /// total: cells planned; already_done: those a resumed file holds. interactive: draw a bar.
  Progress(std::size_t total, std::size_t already_done, bool interactive);
  /// The cell about to run.
  void begin(const std::string& label);
  /// n cells finished (run or skipped); secs_run: time the cell took, for the plain line.
  void end(std::size_t n, const std::string& outcome);
  /// n cells finished elsewhere (a child process, which printed them): counted, not printed.
  void advance(std::size_t n) { done_ += n; }
  /// A line that must be seen (disagreement, error): clears the bar first.
  void loud(const std::string& line);
  /// Ends the bar with a newline.
  void finish();

 private:
  void draw();
  std::string eta() const;
  std::size_t total_;
  std::size_t done_;
  std::size_t done_at_start_;
  bool interactive_;
  std::string label_;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

}  // namespace nnb::bench
