#pragma once

// Short descriptions of JSON values for error messages ("..., found <value>"),
// shared by the model.json and timeline readers.

#include <string>

#include <nlohmann/json.hpp>

namespace ardy {

// An array or object by its kind and size, anything else by its text (cut at 60 characters).
inline std::string describe_json(const nlohmann::json& value) {
  if (value.is_array()) return "an array of " + std::to_string(value.size());
  if (value.is_object()) return "an object";
  std::string text = value.dump();
  if (text.size() > 60) text = text.substr(0, 57) + "...";
  return text;
}

}  // namespace ardy
