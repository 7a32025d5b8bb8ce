#include "embedded_python.hpp"

#include <dlfcn.h>
#include <unistd.h>

#include <stdexcept>

#if defined(__SANITIZE_ADDRESS__)
// The interpreter is never finalized, and at exit LeakSanitizer cannot follow every pointer CPython keeps
// (thousands of its objects were reported, every one allocated inside libpython). Allocations with
// libpython on their stack are ignored (Python's and the extensions' it calls); ours are still checked.
// LeakSanitizer reads this hook in every program that links the Python adapters.
extern "C" const char* __lsan_default_suppressions() { return "leak:libpython3\n"; }
// Without this, every such program would end by listing the suppressed Python objects on stderr.
extern "C" const char* __lsan_default_options() { return "print_suppressions=0"; }
// Python's extension modules are loaded with dlopen and reach their thread-local storage through
// __tls_get_addr. GCC 12's interceptor of that call takes a block whose address is 16 bytes past a page
// boundary for one with glibc 2.19's header and records the two words before it as a range to scan; at
// exit LeakSanitizer's tracer then faults on that range ("Tracer caught signal 11"), now and then, as
// addresses fall. Without the interceptor no dynamic TLS is scanned: fewer roots, so a leak can only be
// reported more readily, never hidden.
extern "C" const char* __asan_default_options() { return "intercept_tls_get_addr=0"; }
#endif

namespace nnb::adapters::python {
namespace {

// Under AddressSanitizer, CPython allocates with plain malloc: its own allocator keeps objects in mmap'd
// arenas that LeakSanitizer does not scan, so everything they point to would be reported as leaked.
void choose_allocator() {
#if defined(__SANITIZE_ADDRESS__)
  PyPreConfig pre;
  PyPreConfig_InitIsolatedConfig(&pre);  // as pybind11's configuration: environment read, locale untouched
  pre.isolated = 0;
  pre.use_environment = 1;
  pre.allocator = PYMEM_ALLOCATOR_MALLOC;
  const PyStatus status = Py_PreInitialize(&pre);
  if (PyStatus_Exception(status)) throw std::runtime_error("embedded Python: pre-initialisation failed");
#endif
}

// Starts the interpreter (unless the process already runs one) and releases the GIL. Returns the pid.
pid_t start_interpreter() {
  if (!Py_IsInitialized()) {
    choose_allocator();
    py::initialize_interpreter(false);  // no signal handlers: the drivers own SIGINT
    PyEval_SaveThread();
  }
  return ::getpid();
}

// After a fork the child's interpreter still believes in the parent's threads and locks.
void repair_after_fork(pid_t started_in) {
  static pid_t repaired_for = started_in;  // read and written under the GIL
  const pid_t now = ::getpid();
  if (now != repaired_for) {
    PyOS_AfterFork_Child();
    repaired_for = now;
  }
}

}  // namespace

Session::Session() {
  static const pid_t started_in = start_interpreter();  // once per process, thread-safe
  state_ = PyGILState_Ensure();
  repair_after_fork(started_in);
}

py::array_t<double> view_of(const Cloud& cloud) {
  const auto n = static_cast<py::ssize_t>(cloud.cols());
  double* data = const_cast<double*>(cloud.data());
  const py::buffer_info columns(data, sizeof(double), py::format_descriptor<double>::format(), 2, {n, py::ssize_t{3}},
                                {py::ssize_t{3 * sizeof(double)}, py::ssize_t{sizeof(double)}}, /*readonly=*/true);
  // A base object makes the array a view (no copy); the capsule owns nothing, the cloud keeps its memory.
  return py::array_t<double>(columns, py::capsule(data, [](void*) {}));
}

std::string module_version(const char* module, const char* distribution) {
  const py::module_ mod = py::module_::import(module);
  if (py::hasattr(mod, "__version__")) return py::str(mod.attr("__version__"));
  try {
    return py::str(py::module_::import("importlib.metadata").attr("version")(distribution));
  } catch (const py::error_already_set&) {
    return "";
  }
}

namespace {

// libgomp as the Python extensions loaded it (RTLD_LOCAL, so not in the global scope): nullptr while no
// extension has loaded it. Called under the GIL.
void* loaded_libgomp() {
  static void* handle = nullptr;
  if (!handle) handle = ::dlopen("libgomp.so.1", RTLD_LAZY | RTLD_NOLOAD);
  return handle;
}

template <class Fn>
Fn* omp_function(const char* name) {
  void* const lib = loaded_libgomp();
  return lib ? reinterpret_cast<Fn*>(::dlsym(lib, name)) : nullptr;
}

}  // namespace

OmpThreads::OmpThreads(int threads) {
  const auto get = omp_function<int()>("omp_get_max_threads");
  const auto set = omp_function<void(int)>("omp_set_num_threads");
  if (get && set) {
    previous_ = get();
    set(threads);
  }
}

OmpThreads::~OmpThreads() {
  if (previous_ > 0) omp_function<void(int)>("omp_set_num_threads")(previous_);
}

}  // namespace nnb::adapters::python
