#include "isolation.hpp"

#include "files.hpp"
#include "results_file.hpp"

#include <poll.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstring>
#include <iostream>
#include <sstream>

namespace nnb::sweep {
namespace {

// The child's sink: each batch one line of JSON down the pipe.
class PipeSink final : public ResultsSink {
 public:
  PipeSink(int fd, const ResultsSink& known) : fd_(fd), known_(known) {}
  const Record* find(const std::string& name) const override { return known_.find(name); }
  void add(const std::vector<Record>& batch) override {
    const std::string line = batch_to_json_line(batch) + "\n";
    for (std::size_t sent = 0; sent < line.size();) {
      const ssize_t n = ::write(fd_, line.data() + sent, line.size() - sent);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) ::_exit(3);  // the parent is gone
      sent += static_cast<std::size_t>(n);
    }
    if (files::interrupted()) ::_exit(0);  // the parent writes the checkpoint and stops
  }

 private:
  int fd_;
  const ResultsSink& known_;
};

[[noreturn]] void run_child(int fd, const ResultsSink& known, const std::function<void(ResultsSink&)>& body) {
  ::prctl(PR_SET_PDEATHSIG, SIGKILL);  // never outlive a killed sweep
  PipeSink sink(fd, known);
  try {
    body(sink);
  } catch (const std::exception& e) {
    std::cerr << "run_sweep: child: " << e.what() << "\n";
    ::_exit(4);
  }
  ::close(fd);
  ::_exit(0);  // no destructors of the parent's objects, no atexit handlers twice
}

// Kills and reaps the child unless it was reaped already: no zombie on any path, exceptions included.
struct ChildGuard {
  pid_t pid;
  bool reaped = false;
  int wait_status() {
    int status = 0;
    while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
    }
    reaped = true;
    return status;
  }
  ~ChildGuard() {
    if (!reaped) {
      ::kill(pid, SIGKILL);
      wait_status();
    }
  }
};

std::string failure_of(int status) {
  if (WIFSIGNALED(status)) {
    const int signal = WTERMSIG(status);
    return std::string("crashed: killed by signal ") + std::to_string(signal) + " (" + strsignal(signal) + ")";
  }
  if (WIFEXITED(status) && WEXITSTATUS(status) != 0) {
    return "crashed: exited with code " + std::to_string(WEXITSTATUS(status));
  }
  return "";
}

std::string seconds_text(double s) {
  std::ostringstream out;
  out << s;
  return out.str();
}

}  // namespace

std::string run_in_child(const ResultsSink& known, const std::function<void(ResultsSink&)>& body,
                         const std::function<void(const std::vector<Record>&)>& on_batch, double timeout_s) {
  int fds[2];
  if (::pipe(fds) != 0) throw std::runtime_error(std::string("pipe: ") + std::strerror(errno));
  std::cout.flush();
  std::cerr.flush();
  const pid_t pid = ::fork();
  if (pid < 0) throw std::runtime_error(std::string("fork: ") + std::strerror(errno));
  if (pid == 0) {
    ::close(fds[0]);
    run_child(fds[1], known, body);
  }
  ::close(fds[1]);
  ChildGuard child{pid};
  struct Reader {
    int fd;
    ~Reader() { ::close(fd); }
  } reader{fds[0]};

  std::string pending;
  auto last_batch = std::chrono::steady_clock::now();
  char buffer[1 << 16];
  for (;;) {
    pollfd p{reader.fd, POLLIN, 0};
    const int ready = ::poll(&p, 1, 200);
    if (files::interrupted()) return "interrupted";
    if (ready > 0) {
      const ssize_t n = ::read(reader.fd, buffer, sizeof buffer);
      if (n == 0) break;  // the child closed its end: finished or died
      if (n < 0) {
        if (errno == EINTR) continue;
        throw std::runtime_error(std::string("reading from the child: ") + std::strerror(errno));
      }
      pending.append(buffer, static_cast<std::size_t>(n));
      for (std::size_t end; (end = pending.find('\n')) != std::string::npos;) {
        on_batch(batch_from_json_line(pending.substr(0, end)));
        pending.erase(0, end + 1);
        last_batch = std::chrono::steady_clock::now();
      }
    }
    const double quiet_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - last_batch).count();
    if (quiet_s > timeout_s) {
      return "timed out: no cell finished within " + seconds_text(timeout_s) + " s (killed)";
    }
  }
  return failure_of(child.wait_status());
}

bool is_failure(const Record& r) {
  return r.skipped.rfind("crashed: ", 0) == 0 || r.skipped.rfind("timed out: ", 0) == 0;
}

}  // namespace nnb::sweep
