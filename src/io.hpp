#pragma once

// Whole-file reads with errors that name the file and say what was expected.

#include <cstddef>
#include <string>

#include "error.hpp"

namespace ardy {

// Reads a whole file as bytes. Throws Error "<path>: file not found (expected
// <expected>)", "...: not a regular file ...", "...: cannot read ...", or
// "...: larger than <max_bytes> bytes ..." when it is too large to be what
// it claims to be.
std::string read_file(const std::string& path, const std::string& expected, size_t max_bytes);

}  // namespace ardy
