// Fuzz target: the experiment-file parser (load_experiment, then validate) on arbitrary bytes.
#include "fuzz_loader.hpp"
#include "sweep/experiment.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = nnb::fuzz::scratch_path(".json");
  nnb::fuzz::write_bytes(path, data, size);
  const std::vector<std::string> adapters{"brute_force", "nanoflann_kdtree", "ours_kdtree"};
  try {
    const auto experiment = nnb::sweep::load_experiment(path, adapters);
    nnb::sweep::validate(experiment, adapters);
  } catch (const nnb::InputError&) {
  }
  return 0;
}
