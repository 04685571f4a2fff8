// The external-data scanner of the package loader (src/onnx_external_data.hpp)
// on raw bytes: it must refuse malformed protobuf with an ardy::Error, never
// read out of bounds or recurse without limit. Also unsafe_path_reason on the
// input as a file name, and both verdicts on every location the scan finds.

#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_common.hpp"
#include "onnx_external_data.hpp"

namespace {

// Leaves the folder it is resolved in: absolute, or a ".." component ("..x"
// is an ordinary name). The scanner's rule is stricter; this is what it must
// never let through.
bool escapes(const std::string& path) {
  const auto ends_with = [&](const char* tail) {
    const std::string end(tail);
    return path.size() >= end.size() && path.compare(path.size() - end.size(), end.size(), end) == 0;
  };
  return path.empty() || path.front() == '/' || path == ".." || path.compare(0, 3, "../") == 0 ||
         path.find("/../") != std::string::npos || ends_with("/..") || path.find('\\') != std::string::npos;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  ardy_fuzz::refusals_allowed([&] {
    for (const auto& t : ardy::onnx_scan::external_tensors(data, size, "fuzz.onnx")) {
      if (ardy::onnx_scan::unsafe_path_reason(t.location).empty() && escapes(t.location)) {
        ardy_fuzz::broken("unsafe location accepted: '" + t.location + "'");
      }
    }
  });
  const std::string name(reinterpret_cast<const char*>(data), size);
  if (ardy::onnx_scan::unsafe_path_reason(name).empty() && escapes(name)) {
    ardy_fuzz::broken("unsafe file name accepted: '" + name + "'");
  }
  return 0;
}
