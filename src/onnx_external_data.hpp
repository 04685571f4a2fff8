#pragma once

// Finds the tensors of an ONNX model (ModelProto bytes) whose data lives in
// an external file, without a protobuf library: a small, bounded scanner of
// the wire format that follows only the fields that can hold tensors.
//
// Why: ONNX Runtime reads TensorProto.external_data "location" relative to
// the graph's folder, or the process's working folder for a graph given as
// bytes, and happily follows "../" or an absolute path. A package from an
// untrusted source must not make the runtime read outside it, so the loader
// (package.cpp) checks every location before ONNX Runtime sees the graph.
//
// Followed (onnx.proto field numbers): ModelProto.graph (7),
// .training_info (20) -> TrainingInfoProto.initialization (1) / .algorithm
// (2), .functions (25) -> FunctionProto.node (7); GraphProto.node (1),
// .initializer (5), .sparse_initializer (15); NodeProto.attribute (5);
// AttributeProto.t (5), .g (6), .tensors (10), .graphs (11),
// .sparse_tensor (22), .sparse_tensors (23); SparseTensorProto.values (1),
// .indices (2); TensorProto.name (8), .external_data (13:
// StringStringEntryProto key 1, value 2), .data_location (14, EXTERNAL = 1).
// Everything else is skipped by its wire type. Malformed bytes (truncated
// fields, bad wire types, nesting deeper than kMaxDepth) are an Error: ONNX
// Runtime would refuse them anyway, and a scan that gave up could not vouch
// for the rest.

#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "error.hpp"

namespace ardy::onnx_scan {

struct ExternalTensor {
  std::string tensor;    // TensorProto.name ("" if unnamed)
  std::string location;  // external_data "location" ("" if none given)
};

// Messages nested deeper than this (graphs in attributes of nodes of graphs...)
// are refused; protobuf's own default limit is 100.
inline constexpr int kMaxDepth = 64;

namespace detail {

enum class Kind { model, training_info, function, graph, node, attribute, sparse_tensor, tensor, entry };

class Scanner {
 public:
  Scanner(const uint8_t* data, size_t size, std::string what) : base_(data), size_(size), what_(std::move(what)) {}

  std::vector<ExternalTensor> run() {
    scan(0, size_, Kind::model, 0);
    return std::move(found_);
  }

 private:
  [[noreturn]] void fail(size_t at, const std::string& why) const {
    throw Error(what_ + ": not a valid ONNX model (" + why + " at byte " + std::to_string(at) + ")");
  }

  uint64_t varint(size_t& pos, size_t end) const {
    uint64_t value = 0;
    for (int shift = 0; shift < 64; shift += 7) {
      if (pos >= end) fail(pos, "truncated varint");
      const uint8_t byte = base_[pos++];
      value |= uint64_t(byte & 0x7f) << shift;
      if (!(byte & 0x80)) return value;
    }
    fail(pos, "varint longer than 10 bytes");
  }

  // The message kind a length-delimited field holds, or nothing to follow.
  static bool child(Kind parent, uint64_t field, Kind& out) {
    switch (parent) {
      case Kind::model:
        if (field == 7) return out = Kind::graph, true;
        if (field == 20) return out = Kind::training_info, true;
        if (field == 25) return out = Kind::function, true;
        return false;
      case Kind::training_info:
        if (field == 1 || field == 2) return out = Kind::graph, true;
        return false;
      case Kind::function:
        if (field == 7) return out = Kind::node, true;
        return false;
      case Kind::graph:
        if (field == 1) return out = Kind::node, true;
        if (field == 5) return out = Kind::tensor, true;
        if (field == 15) return out = Kind::sparse_tensor, true;
        return false;
      case Kind::node:
        if (field == 5) return out = Kind::attribute, true;
        return false;
      case Kind::attribute:
        if (field == 5 || field == 10) return out = Kind::tensor, true;
        if (field == 6 || field == 11) return out = Kind::graph, true;
        if (field == 22 || field == 23) return out = Kind::sparse_tensor, true;
        return false;
      case Kind::sparse_tensor:
        if (field == 1 || field == 2) return out = Kind::tensor, true;
        return false;
      case Kind::tensor:
        if (field == 13) return out = Kind::entry, true;
        return false;
      case Kind::entry: return false;
    }
    return false;
  }

  // Scans the message in [begin, end). For a tensor, records it when it is
  // external; for an entry, fills key_ / value_.
  void scan(size_t begin, size_t end, Kind kind, int depth) {
    if (depth > kMaxDepth) fail(begin, "messages nested deeper than " + std::to_string(kMaxDepth));
    std::string name;
    std::vector<std::string> locations;  // every "location" entry: which one ONNX Runtime uses is its business
    bool external = false;
    size_t pos = begin;
    while (pos < end) {
      const size_t at = pos;
      const uint64_t key = varint(pos, end);
      const uint64_t field = key >> 3;
      if (field == 0) fail(at, "field number 0");
      switch (key & 7) {
        case 0: {
          const uint64_t value = varint(pos, end);
          if (kind == Kind::tensor && field == 14 && value == 1) external = true;
          break;
        }
        case 1:
          if (end - pos < 8) fail(at, "truncated 64-bit field");
          pos += 8;
          break;
        case 5:
          if (end - pos < 4) fail(at, "truncated 32-bit field");
          pos += 4;
          break;
        case 2: {
          const uint64_t length = varint(pos, end);
          if (length > end - pos) fail(at, "field " + std::to_string(field) + " longer than its message");
          const size_t stop = pos + static_cast<size_t>(length);
          Kind sub;
          if (kind == Kind::tensor && field == 8) {
            name.assign(reinterpret_cast<const char*>(base_ + pos), stop - pos);
          } else if (kind == Kind::entry && (field == 1 || field == 2)) {
            (field == 1 ? key_ : value_).assign(reinterpret_cast<const char*>(base_ + pos), stop - pos);
          } else if (child(kind, field, sub)) {
            if (sub == Kind::entry) {
              key_.clear();
              value_.clear();
              scan(pos, stop, sub, depth + 1);
              external = true;  // any external_data entry means the data is elsewhere
              if (key_ == "location") locations.push_back(value_);
            } else {
              scan(pos, stop, sub, depth + 1);
            }
          }
          pos = stop;
          break;
        }
        default: fail(at, "wire type " + std::to_string(key & 7) + " (groups are not used by ONNX)");
      }
    }
    if (kind == Kind::tensor && external) {
      if (locations.empty()) locations.emplace_back();
      for (std::string& location : locations) found_.push_back({name, std::move(location)});
    }
  }

  const uint8_t* base_;
  size_t size_;
  std::string what_;
  std::string key_, value_;  // the last StringStringEntryProto scanned
  std::vector<ExternalTensor> found_;
};

}  // namespace detail

// Every tensor of the model with external data, in file order, once per
// "location" entry it has (once with "" when it has none). `what` names the
// graph in errors ("package/denoiser.onnx").
inline std::vector<ExternalTensor> external_tensors(const void* data, size_t size, const std::string& what) {
  if (size == 0) return {};
  if (data == nullptr) throw Error(what + ": null data pointer with a size of " + std::to_string(size));
  return detail::Scanner(static_cast<const uint8_t*>(data), size, what).run();
}

// Why `name` is not a safe relative path inside a package ("" when it is):
// not empty, not absolute, no drive letter or ':' (Windows streams), no
// backslash, no NUL, and no empty, "." or ".." component. Package file names
// in model.json and external-data locations both use it.
inline std::string unsafe_path_reason(const std::string& name) {
  if (name.empty()) return "is empty";
  if (name.find('\0') != std::string::npos) return "contains a NUL character";
  if (name.front() == '/') return "is an absolute path";
  if (name.find('\\') != std::string::npos) return "contains a backslash (Windows path separator; use '/')";
  if (name.find(':') != std::string::npos) return "contains ':' (a drive letter or a Windows stream)";
  size_t begin = 0;
  while (true) {
    const size_t slash = name.find('/', begin);
    const std::string part = name.substr(begin, slash == std::string::npos ? std::string::npos : slash - begin);
    if (part == "..") return "has a '..' component (leaves the package)";
    if (part.empty() || part == ".") return "has an empty or '.' path component";
    if (slash == std::string::npos) return "";
    begin = slash + 1;
  }
}

}  // namespace ardy::onnx_scan
