#pragma once
#include <string>

namespace nnb::datasets {

/// The sha256 of the file's bytes as 64 lowercase hex digits (OpenSSL EVP); InputError if unreadable.
std::string sha256_file(const std::string& path);

}  // namespace nnb::datasets
