// The external-data scanner of the package loader (src/onnx_external_data.hpp)
// on raw bytes: it must refuse malformed protobuf with an ardy::Error, never
// read out of bounds or recurse without limit. Also unsafe_path_reason on the
// input as a file name, and both verdicts on every location the scan finds.

#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_common.hpp"
#include "onnx_external_data.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  ardy_fuzz::refusals_allowed([&] {
    for (const auto& t : ardy::onnx_scan::external_tensors(data, size, "fuzz.onnx")) {
      const std::string reason = ardy::onnx_scan::unsafe_path_reason(t.location);
      if (reason.empty() && (t.location.empty() || t.location.front() == '/' ||
                             t.location.find("..") == 0 || t.location.find("/../") != std::string::npos)) {
        ardy_fuzz::broken("unsafe location accepted: '" + t.location + "'");
      }
    }
  });
  const std::string name(reinterpret_cast<const char*>(data), size);
  const std::string reason = ardy::onnx_scan::unsafe_path_reason(name);
  if (reason.empty() && (name.empty() || name == ".." || name.compare(0, 3, "../") == 0 ||
                         name.find("/../") != std::string::npos || name.front() == '/' ||
                         name.find('\\') != std::string::npos)) {
    ardy_fuzz::broken("unsafe file name accepted: '" + name + "'");
  }
  return 0;
}
