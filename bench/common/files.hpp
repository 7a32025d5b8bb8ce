#pragma once
// Output files every program writes the same way: atomically, never over an input, one writer at a time,
// and checked before any work is done so that a bad path fails at once.
#include <string>
#include <vector>

namespace nnb::files {

/// Writes text to path through a temporary file in the same directory, fsync and a rename, so that a
/// reader never sees a half-written file; the temporary is removed on every failure path. Throws
/// InputError with one line when the file cannot be written.
void write_file_atomically(const std::string& path, const std::string& text);

/// The temporary write_file_atomically writes path through, in this process: for a writer that streams
/// (Google Benchmark's --benchmark_out) into it, then moves it in place with commit_temporary.
std::string temporary_path(const std::string& path);
/// Moves path's temporary (temporary_path) in place, after an fsync; InputError with one line when it
/// cannot (the temporary is then removed).
void commit_temporary(const std::string& path);

/// Refuses (InputError) an output path that cannot be written: a directory, a folder that cannot be
/// created or written, or one of the inputs (compared as files, not as names). Writes nothing.
void check_output_path(const std::string& path, const std::vector<std::string>& inputs = {});

/// Removes temporaries a killed writer left beside path (".<name>.tmp.<pid>" of processes no longer
/// alive). Call while holding the path's OutputLock.
void remove_stale_temporaries(const std::string& path);

/// An exclusive lock on an output file (flock on "<path>.lock"), held for the object's life: a second
/// process writing the same file is refused at once with InputError. The lock file is removed on release.
class OutputLock {
 public:
  explicit OutputLock(const std::string& path);
  ~OutputLock();
  OutputLock(const OutputLock&) = delete;
  OutputLock& operator=(const OutputLock&) = delete;

 private:
  std::string lock_path_;
  int fd_ = -1;
};

/// The experiment file for a name (experiments_dir/NAME.json) or a path; InputError when it is neither.
std::string experiment_path(const std::string& name_or_file, const std::string& experiments_dir);

/// SIGINT and SIGTERM set a flag instead of killing the process, so that the current checkpoint is
/// finished; the program polls interrupted() between cells and stops cleanly.
void catch_interrupts();
/// The signal that asked the program to stop, 0 when none did.
int interrupted();

}  // namespace nnb::files
