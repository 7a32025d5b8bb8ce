#pragma once
// Tests on the real scans run whenever the data is found (nnb::datasets::default_data_dir()) and are
// skipped otherwise, with the command that fetches it. NNB_REQUIRE_REAL_DATA=1 (CI, which has the data)
// turns every such skip into a failure, so a lost data folder cannot pass unnoticed.
#include "nnb/datasets/catalog.hpp"
#include "nnb/datasets/manifest.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>

namespace nnb::test {

/// Every pair's model and query scan is in the data directory (present, not checksum-checked).
inline bool real_data_present() {
  const std::filesystem::path dir = nnb::datasets::default_data_dir();
  for (const auto& pair : nnb::datasets::real_pairs()) {
    for (const auto* scan : {&pair.model, &pair.query}) {
      std::error_code error;
      if (!std::filesystem::is_regular_file(dir / pair.folder / scan->file, error)) return false;
    }
  }
  return true;
}

inline bool real_data_required() {
  const char* env = std::getenv("NNB_REQUIRE_REAL_DATA");
  return env != nullptr && *env != '\0' && std::strcmp(env, "0") != 0;
}

}  // namespace nnb::test

/// First statement of a test (or of its part) that reads the real scans: skip it when they are missing.
#define NNB_SKIP_WITHOUT_REAL_DATA()                                                                      \
  do {                                                                                                    \
    if (!::nnb::test::real_data_present()) {                                                              \
      if (::nnb::test::real_data_required()) {                                                            \
        FAIL() << "real scans not found in " << ::nnb::datasets::default_data_dir()                       \
               << " and NNB_REQUIRE_REAL_DATA is set: run scripts/fetch_data.sh";                         \
      }                                                                                                   \
      GTEST_SKIP() << "real scans not found: run scripts/fetch_data.sh";                                  \
    }                                                                                                     \
  } while (false)
