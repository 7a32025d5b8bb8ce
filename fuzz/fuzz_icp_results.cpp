// Fuzz target: run_icp --resume's reader (read_resumable) on arbitrary bytes. The configuration it is
// resumed with is fixed and the seeds carry it, so that inputs get past the configuration check to the
// records.
#include "fuzz_loader.hpp"
#include "icp_record.hpp"

#include <cstdlib>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = nnb::fuzz::scratch_path(".json");
  nnb::fuzz::write_bytes(path, data, size);
  const nnb::icp::RunContext run{"icp_fuzz", "", R"({"experiment":"icp_fuzz","repetitions":2})", ""};
  try {
    const auto resumed = nnb::icp::read_resumable(path, run);
    if (resumed.records.size() != resumed.cells.size()) std::abort();  // one cell name per record kept
  } catch (const nnb::InputError&) {
  }
  return 0;
}
