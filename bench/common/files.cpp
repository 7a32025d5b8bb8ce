#include "files.hpp"

#include "nnb/cloud.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>

namespace nnb::files {
namespace fs = std::filesystem;
namespace {

fs::path folder_of(const fs::path& target) { return target.has_parent_path() ? target.parent_path() : fs::path("."); }

std::string temporary_prefix(const fs::path& target) { return "." + target.filename().string() + ".tmp."; }

fs::path temporary_for(const fs::path& target) {
  return folder_of(target) / (temporary_prefix(target) + std::to_string(::getpid()));
}

bool process_alive(long pid) { return pid > 0 && (::kill(static_cast<pid_t>(pid), 0) == 0 || errno == EPERM); }

std::atomic<int> g_interrupt{0};

extern "C" void on_interrupt(int signal) { g_interrupt.store(signal); }

}  // namespace

void write_file_atomically(const std::string& path, const std::string& text) {
  const fs::path target(path);
  std::error_code ec;
  fs::create_directories(folder_of(target), ec);
  const fs::path temp = temporary_for(target);
  std::FILE* file = std::fopen(temp.c_str(), "wb");
  if (file == nullptr) throw InputError("cannot write " + temp.string() + ": " + std::strerror(errno));
  const bool written = std::fwrite(text.data(), 1, text.size(), file) == text.size();
  const bool flushed = std::fflush(file) == 0 && ::fsync(::fileno(file)) == 0;
  const int error = errno;
  const bool closed = std::fclose(file) == 0;
  if (!written || !flushed || !closed) {
    fs::remove(temp, ec);
    throw InputError("cannot write " + path + ": " + std::strerror(error ? error : errno));
  }
  fs::rename(temp, target, ec);
  if (ec) {
    std::error_code ignored;
    fs::remove(temp, ignored);
    throw InputError("cannot replace " + path + ": " + ec.message());
  }
}

std::string temporary_path(const std::string& path) { return temporary_for(fs::path(path)).string(); }

void commit_temporary(const std::string& path) {
  const fs::path target(path);
  const fs::path temp = temporary_for(target);
  std::error_code ec;
  const int fd = ::open(temp.c_str(), O_RDONLY | O_CLOEXEC);
  const bool synced = fd >= 0 && ::fsync(fd) == 0;
  const int error = errno;
  if (fd >= 0) ::close(fd);
  if (synced) fs::rename(temp, target, ec);
  if (!synced || ec) {
    std::error_code ignored;
    fs::remove(temp, ignored);
    throw InputError("cannot write " + path + ": " + (synced ? ec.message() : std::strerror(error)));
  }
}

void check_output_path(const std::string& path, const std::vector<std::string>& inputs) {
  if (path.empty()) throw InputError("the output path is empty");
  const fs::path target(path);
  std::error_code ec;
  if (fs::is_directory(target, ec)) throw InputError("output " + path + " is a directory: give a file name");
  for (const auto& input : inputs) {
    if (fs::exists(target, ec) && fs::exists(input, ec) && fs::equivalent(target, input, ec)) {
      throw InputError("output " + path + " is the input file " + input + ": refusing to overwrite it");
    }
  }
  const fs::path folder = folder_of(target);
  fs::create_directories(folder, ec);
  if (!fs::is_directory(folder)) throw InputError("cannot create the folder of " + path);
  // A real probe: permissions alone do not tell about read-only mounts, /proc or a full quota.
  const fs::path probe = temporary_for(target);
  const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL, 0644);
  if (fd < 0) throw InputError("cannot write " + path + ": " + std::strerror(errno));
  ::close(fd);
  fs::remove(probe, ec);
}

void remove_stale_temporaries(const std::string& path) {
  const fs::path target(path);
  const std::string prefix = temporary_prefix(target);
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(folder_of(target), ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind(prefix, 0) != 0) continue;
    const long pid = std::strtol(name.c_str() + prefix.size(), nullptr, 10);
    if (!process_alive(pid)) fs::remove(entry.path(), ec);
  }
}

OutputLock::OutputLock(const std::string& path) : lock_path_(path + ".lock") {
  std::error_code ec;
  fs::create_directories(folder_of(fs::path(path)), ec);
  fd_ = ::open(lock_path_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0) throw InputError("cannot create the lock " + lock_path_ + ": " + std::strerror(errno));
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    ::close(fd_);
    fd_ = -1;
    throw InputError("another process is writing " + path + " (it holds " + lock_path_ + "): wait for it or use "
                     "another --out");
  }
}

OutputLock::~OutputLock() {
  if (fd_ < 0) return;
  ::unlink(lock_path_.c_str());
  ::close(fd_);
}

std::string experiment_path(const std::string& name_or_file, const std::string& experiments_dir) {
  const fs::path by_name = fs::path(experiments_dir) / (name_or_file + ".json");
  if (name_or_file.find('/') == std::string::npos && fs::is_regular_file(by_name)) return by_name.string();
  if (fs::is_regular_file(name_or_file)) return name_or_file;
  throw InputError("--experiment: '" + name_or_file + "' is neither a file nor an experiment in " + experiments_dir);
}

void catch_interrupts() {
  struct sigaction action {};
  action.sa_handler = on_interrupt;
  sigemptyset(&action.sa_mask);
  ::sigaction(SIGINT, &action, nullptr);
  ::sigaction(SIGTERM, &action, nullptr);
}

int interrupted() { return g_interrupt.load(); }

}  // namespace nnb::files
