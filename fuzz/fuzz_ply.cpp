// Fuzz target: the ply loader on arbitrary bytes.
#include "fuzz_loader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return nnb::fuzz::load_bytes(data, size, nnb::datasets::PointFormat::ply, ".ply");
}
