// Fuzz target: the results-file reader behind run_sweep --resume and --retry-failed (parse_results) on
// arbitrary bytes. Beyond not crashing, what it reads must survive being written back: resume rewrites
// each record's text as read, and a child hands its records over as to_json writes them; both must read
// back to the same record, or the next --resume would refuse the file the run itself wrote.
#include "nnb/cloud.hpp"
#include "sweep/results_file.hpp"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <vector>

namespace {

// batch_from_json_line throws nlohmann's exceptions, which this file does not see: any escape is a finding.
std::vector<nnb::sweep::Record> read_back(const std::string& line) {
  try {
    return nnb::sweep::batch_from_json_line(line);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "a record read from the file does not read back: %s\n%s\n", e.what(), line.c_str());
    std::abort();
  }
}

void expect_same(const std::vector<nnb::sweep::Record>& read, const std::vector<nnb::sweep::Record>& again) {
  const std::string first = nnb::sweep::batch_to_json_line(read);
  const std::string second = nnb::sweep::batch_to_json_line(again);
  if (first == second) return;
  std::fprintf(stderr, "a record changed on its way back:\n%s\n%s\n", first.c_str(), second.c_str());
  std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  std::vector<nnb::sweep::StoredRecord> stored;
  try {
    const bool retry_failed = size % 2 == 1;  // both ways, chosen by the input
    stored = nnb::sweep::parse_results(text, "fuzz.json", retry_failed);
  } catch (const nnb::InputError&) {
    return 0;
  }
  std::vector<nnb::sweep::Record> records;
  std::string rewritten = "[";
  for (const auto& s : stored) {
    records.push_back(s.record);
    (rewritten += rewritten.size() > 1 ? "," : "") += s.json;
  }
  expect_same(records, read_back(rewritten + "]"));
  expect_same(records, read_back(nnb::sweep::batch_to_json_line(records)));
  return 0;
}
