// Fuzz target: run_icp's experiment-file parser (load_experiment) on arbitrary bytes.
#include "fuzz_loader.hpp"
#include "icp_experiment.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = nnb::fuzz::scratch_path(".json");
  nnb::fuzz::write_bytes(path, data, size);
  try {
    (void)nnb::icp::load_experiment(path);
  } catch (const nnb::InputError&) {
  }
  return 0;
}
