#pragma once
// One embedded CPython per process for the Python libraries' adapters. The interpreter starts on the first
// use (never when an adapter is only constructed, so listing adapters costs nothing), is never finalized
// (numpy and scipy do not survive a restart), and lives with the GIL released: each batch takes it.
// A process forked after the start (the sweep's children) repairs the interpreter's thread state on its
// first use, as os.fork() would.
#include "nnb/cloud.hpp"

#include <pybind11/embed.h>
#include <pybind11/numpy.h>

#include <string>

namespace nnb::adapters::python {

namespace py = pybind11;

/// Holds the GIL of the process's embedded interpreter, starting the interpreter if needed.
class Session {
 public:
  Session();
  ~Session() { PyGILState_Release(state_); }
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

 private:
  PyGILState_STATE state_;
};

/// A read-only (n, 3) float64 numpy array over the cloud's own memory (no copy): the cloud must outlive
/// every Python object that keeps the array. The cloud must not be empty.
py::array_t<double> view_of(const Cloud& cloud);

/// The module's __version__, else its distribution's version ("" when neither is known).
std::string module_version(const char* module, const char* distribution);

/// Runs OpenMP regions entered in its scope on the given number of threads (pykdtree parallelises each
/// query call over every core otherwise, with a thread team start-up of ~0.5 ms a call); restores the
/// setting after.
class OmpThreads {
 public:
  explicit OmpThreads(int threads);
  ~OmpThreads();
  OmpThreads(const OmpThreads&) = delete;
  OmpThreads& operator=(const OmpThreads&) = delete;

 private:
  int previous_ = 0;
};

}  // namespace nnb::adapters::python
