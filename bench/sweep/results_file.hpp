#pragma once
// The results file: Google Benchmark's JSON schema (context + benchmarks[]), rewritten atomically
// (temporary file in the same directory, then rename) at checkpoints of a bounded rate.
#include "experiment.hpp"
#include "machine.hpp"
#include "record.hpp"
#include "runner.hpp"

#include <chrono>
#include <cstddef>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

namespace nnb::sweep {

using bench::BuildInfo;
using bench::MachineInfo;

struct RunDescription {
  const Experiment* experiment;
  const std::vector<PlannedAdapter>* adapters;
  const LoadedData* data;
  MachineInfo machine;
  BuildInfo build;
  std::string shard_config;   ///< JSON joined to context.config as "shard"; empty when not sharded (shard.hpp)
  std::string shard_context;  ///< JSON put in context as "shard"
};

/// A checkpoint batch as one line of JSON (records as in the file), and back: how a child process
/// hands its cells to the sweep.
std::string batch_to_json_line(const std::vector<Record>& batch);
std::vector<Record> batch_from_json_line(const std::string& line);

/// A record read back from a results file, with its JSON text as the file is rewritten with it.
struct StoredRecord {
  Record record;
  std::string json;
};
/// The records of a results file's text in file order, the first of each name kept (without the cells
/// whose child crashed or timed out when retry_failed): what resume() reads, short of the configuration
/// check. Throws InputError naming path when the text is not a results file or a record is malformed.
std::vector<StoredRecord> parse_results(const std::string& text, const std::string& path, bool retry_failed = false);

class ResultsFile final : public ResultsSink {
 public:
  /// A results file at path for this run; nothing is written before the first add() or write().
  ResultsFile(std::string path, const RunDescription& run);
  ~ResultsFile() override;

  /// Loads the records of an existing file made with the same configuration (without the cells whose
  /// child crashed or timed out when retry_failed); throws InputError if the file is unreadable or its
  /// configuration differs. Returns false when there is no file.
  bool resume(bool retry_failed = false);
  /// Records already in the file (after resume()) and added since.
  const std::vector<Record>& records() const { return records_; }

  const Record* find(const std::string& name) const override;
  void add(const std::vector<Record>& batch) override;
  /// Writes the whole file atomically now; throws InputError on an I/O failure.
  void write();

  /// Calls after each checkpoint, for the kill test: raise SIGKILL once this many cells are recorded.
  void abort_after(std::size_t cells) { abort_after_ = cells; }

 private:
  struct Json;
  std::string path_;
  std::unique_ptr<Json> json_;  // context and config, nlohmann kept out of this header
  std::vector<Record> records_;
  std::vector<std::string> serialised_;  // each record's JSON text, made once
  std::map<std::string, std::size_t> where_;  // a cell's place in records_
  bool checkpoint_due() const;
  std::size_t added_ = 0;
  std::size_t pending_bytes_ = 0;  // serialised since the last write
  std::size_t written_bytes_ = 0;  // size of the last write
  std::chrono::steady_clock::time_point last_write_ = std::chrono::steady_clock::now();
  std::size_t abort_after_ = 0;
};

}  // namespace nnb::sweep
