#pragma once

// Test-only helpers: file paths under tests/data, whole-file reads, and a
// small strict JSON reader for golden vectors (the runtime has no JSON
// dependency yet; this one only needs to read files we generate).

#include <cctype>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#ifndef ARDY_TEST_DATA_DIR
#error "ARDY_TEST_DATA_DIR must be defined by the build (tests/cpp/CMakeLists.txt)"
#endif

namespace ardy_test {

inline std::string data_path(const std::string& relative) { return std::string(ARDY_TEST_DATA_DIR) + "/" + relative; }

inline std::vector<unsigned char> read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open");
  return std::vector<unsigned char>(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

struct JsonValue {
  enum class Kind { null, boolean, number, string, array, object };
  Kind kind = Kind::null;
  bool boolean = false;
  std::string text;  // string contents, or a number's literal (parsed on demand, exactly)
  std::vector<JsonValue> items;
  std::vector<std::pair<std::string, JsonValue>> members;  // in file order

  const JsonValue& at(const std::string& key) const {
    if (kind != Kind::object) throw std::runtime_error("json: not an object (looking up '" + key + "')");
    for (const auto& [name, value] : members) {
      if (name == key) return value;
    }
    throw std::runtime_error("json: no key '" + key + "'");
  }

  // Numbers are parsed from their literal straight to the target type, so a
  // float32 written as its shortest round-trip decimal comes back exactly.
  float as_float() const { return std::strtof(number_text().c_str(), nullptr); }
  int64_t as_int() const { return std::strtoll(number_text().c_str(), nullptr, 10); }

  std::vector<float> floats() const {
    std::vector<float> out;
    for (const JsonValue& item : array_items()) out.push_back(item.as_float());
    return out;
  }
  std::vector<int64_t> ints() const {
    std::vector<int64_t> out;
    for (const JsonValue& item : array_items()) out.push_back(item.as_int());
    return out;
  }

 private:
  const std::string& number_text() const {
    if (kind != Kind::number) throw std::runtime_error("json: not a number");
    return text;
  }
  const std::vector<JsonValue>& array_items() const {
    if (kind != Kind::array) throw std::runtime_error("json: not an array");
    return items;
  }
};

class JsonReader {
 public:
  explicit JsonReader(std::string source) : s_(std::move(source)) {}

  JsonValue parse() {
    JsonValue value = parse_value();
    skip_space();
    if (pos_ != s_.size()) fail("trailing characters");
    return value;
  }

 private:
  [[noreturn]] void fail(const std::string& what) const {
    throw std::runtime_error("json: " + what + " at offset " + std::to_string(pos_));
  }
  void skip_space() {
    while (pos_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[pos_]))) ++pos_;
  }
  char peek() {
    skip_space();
    if (pos_ >= s_.size()) fail("unexpected end");
    return s_[pos_];
  }
  void expect(char c) {
    if (peek() != c) fail(std::string("expected '") + c + "'");
    ++pos_;
  }
  bool literal(const char* word) {
    const std::string w(word);
    if (s_.compare(pos_, w.size(), w) != 0) return false;
    pos_ += w.size();
    return true;
  }

  JsonValue parse_value() {
    JsonValue v;
    const char c = peek();
    if (c == '{') {
      v.kind = JsonValue::Kind::object;
      ++pos_;
      if (peek() == '}') {
        ++pos_;
        return v;
      }
      for (;;) {
        std::string key = parse_string();
        expect(':');
        v.members.emplace_back(std::move(key), parse_value());
        if (peek() == ',') {
          ++pos_;
          continue;
        }
        expect('}');
        return v;
      }
    }
    if (c == '[') {
      v.kind = JsonValue::Kind::array;
      ++pos_;
      if (peek() == ']') {
        ++pos_;
        return v;
      }
      for (;;) {
        v.items.push_back(parse_value());
        if (peek() == ',') {
          ++pos_;
          continue;
        }
        expect(']');
        return v;
      }
    }
    if (c == '"') {
      v.kind = JsonValue::Kind::string;
      v.text = parse_string();
      return v;
    }
    if (literal("true")) {
      v.kind = JsonValue::Kind::boolean;
      v.boolean = true;
      return v;
    }
    if (literal("false")) {
      v.kind = JsonValue::Kind::boolean;
      return v;
    }
    if (literal("null")) return v;
    const size_t start = pos_;
    while (pos_ < s_.size() && (std::isdigit(static_cast<unsigned char>(s_[pos_])) || s_[pos_] == '-' ||
                                s_[pos_] == '+' || s_[pos_] == '.' || s_[pos_] == 'e' || s_[pos_] == 'E')) {
      ++pos_;
    }
    if (start == pos_) fail("unexpected character");
    v.kind = JsonValue::Kind::number;
    v.text = s_.substr(start, pos_ - start);
    return v;
  }

  // Strings in our golden files are plain names: escapes other than \" and
  // \\ are not needed and are refused rather than half-supported.
  std::string parse_string() {
    expect('"');
    std::string out;
    while (pos_ < s_.size() && s_[pos_] != '"') {
      if (s_[pos_] == '\\') {
        ++pos_;
        if (pos_ >= s_.size() || (s_[pos_] != '"' && s_[pos_] != '\\')) fail("unsupported escape");
      }
      out += s_[pos_++];
    }
    if (pos_ >= s_.size()) fail("unterminated string");
    ++pos_;
    return out;
  }

  std::string s_;
  size_t pos_ = 0;
};

inline JsonValue read_json(const std::string& path) {
  const std::vector<unsigned char> bytes = read_bytes(path);
  return JsonReader(std::string(bytes.begin(), bytes.end())).parse();
}

}  // namespace ardy_test
