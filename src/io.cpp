#include "io.hpp"

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <system_error>

namespace ardy {

std::string read_file(const std::string& path, const std::string& expected, size_t max_bytes) {
  std::error_code ec;
  const std::filesystem::path fs_path(path);
  if (!std::filesystem::exists(fs_path, ec)) throw Error(path + ": file not found (expected " + expected + ")");
  if (!std::filesystem::is_regular_file(fs_path, ec)) {
    throw Error(path + ": not a regular file (expected " + expected + ")");
  }
  const std::uintmax_t size = std::filesystem::file_size(fs_path, ec);
  if (ec) throw Error(path + ": cannot read (" + ec.message() + ")");
  if (size > max_bytes) {
    throw Error(path + ": " + std::to_string(size) + " bytes, larger than the " + std::to_string(max_bytes) +
                " bytes allowed for " + expected);
  }
  std::ifstream in(fs_path, std::ios::binary);
  if (!in) throw Error(path + ": cannot open for reading");
  std::string bytes(static_cast<size_t>(size), '\0');
  in.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (static_cast<size_t>(in.gcount()) != bytes.size()) throw Error(path + ": cannot read (short read)");
  return bytes;
}

}  // namespace ardy
