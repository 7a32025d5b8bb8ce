#include "progress.hpp"

#include <cstdio>
#include <iostream>
#include <sstream>

namespace nnb::bench {
namespace {

std::string format_duration(double seconds) {
  const auto s = static_cast<long>(seconds + 0.5);
  std::ostringstream out;
  if (s >= 3600) out << s / 3600 << "h" << (s % 3600) / 60 << "m";
  else if (s >= 60) out << s / 60 << "m" << s % 60 << "s";
  else out << s << "s";
  return out.str();
}

}  // namespace

Progress::Progress(std::size_t total, std::size_t already_done, bool interactive)
    : total_(total), done_(already_done), done_at_start_(already_done), interactive_(interactive) {}

void Progress::begin(const std::string& label) {
  label_ = label;
  if (interactive_) draw();
}

void Progress::end(std::size_t n, const std::string& outcome) {
  done_ += n;
  if (interactive_) {
    draw();
  } else {
    std::cerr << "[" << done_ << "/" << total_ << " ETA " << eta() << "] " << label_ << " " << outcome << "\n";
  }
}

void Progress::loud(const std::string& line) {
  if (interactive_) std::cerr << "\r\033[K";
  std::cerr << line << "\n";
  if (interactive_) draw();
}

void Progress::finish() {
  if (interactive_) std::cerr << "\n";
}

// The ETA assumes the remaining cells cost what the finished ones did on average: rough, since
// cells grow with the distance and budget-skipped ones cost nothing.
std::string Progress::eta() const {
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const std::size_t ran = done_ - done_at_start_;
  const std::size_t left = total_ > done_ ? total_ - done_ : 0;
  return ran > 0 ? format_duration(elapsed / static_cast<double>(ran) * static_cast<double>(left)) : "?";
}

void Progress::draw() {
  constexpr int width = 30;
  const int filled = total_ > 0 ? static_cast<int>(width * done_ / total_) : width;
  std::string bar(static_cast<std::size_t>(filled), '#');
  bar.resize(width, '.');
  std::string label = label_;
  if (label.size() > 70) label = "..." + label.substr(label.size() - 67);
  std::cerr << "\r\033[K[" << bar << "] " << done_ << "/" << total_ << " ETA " << eta() << " " << label << std::flush;
}

}  // namespace nnb::bench
