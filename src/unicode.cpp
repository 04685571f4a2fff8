#include "unicode.hpp"

#include <algorithm>

#include "error.hpp"
#include "unicode_tables.hpp"

namespace ardy::unicode {
namespace {

namespace tables = ardy::unicode_tables;

constexpr char32_t kHangulFirst = 0xAC00;
constexpr char32_t kHangulLast = 0xD7A3;
constexpr char32_t kHangulL = 0x1100;
constexpr char32_t kHangulV = 0x1161;
constexpr char32_t kHangulT = 0x11A7;
constexpr char32_t kHangulVCount = 21;
constexpr char32_t kHangulTCount = 28;
constexpr char32_t kHangulNCount = kHangulVCount * kHangulTCount;  // 588

// The range holding `c` in a sorted, non-overlapping range table, or nullptr.
template <typename Range>
const Range* find_range(const Range* ranges, size_t count, char32_t c) {
  const Range* end = ranges + count;
  const Range* it = std::upper_bound(ranges, end, c, [](char32_t value, const Range& r) { return value < r.first; });
  if (it == ranges) return nullptr;
  --it;
  return c <= it->last ? it : nullptr;
}

const tables::Mapping* find_mapping(const tables::Mapping* mappings, size_t count, char32_t c) {
  const tables::Mapping* end = mappings + count;
  const tables::Mapping* it =
      std::lower_bound(mappings, end, c, [](const tables::Mapping& m, char32_t value) { return m.code_point < value; });
  return it != end && it->code_point == c ? it : nullptr;
}

bool is_continuation(unsigned char byte) { return (byte & 0xC0) == 0x80; }

// Decodes one well-formed sequence at text[pos]; returns its length, or 0 when
// it is ill-formed (Unicode's table 3-7 of well-formed byte sequences).
size_t decode_one(std::string_view text, size_t pos, char32_t& out) {
  const auto byte = [&](size_t i) { return static_cast<unsigned char>(text[i]); };
  const unsigned char b0 = byte(pos);
  const size_t left = text.size() - pos;
  if (b0 < 0x80) {
    out = b0;
    return 1;
  }
  if (b0 >= 0xC2 && b0 <= 0xDF) {
    if (left < 2 || !is_continuation(byte(pos + 1))) return 0;
    out = (char32_t(b0 & 0x1F) << 6) | (byte(pos + 1) & 0x3F);
    return 2;
  }
  if (b0 >= 0xE0 && b0 <= 0xEF) {
    if (left < 3) return 0;
    const unsigned char b1 = byte(pos + 1);
    const unsigned char lo = b0 == 0xE0 ? 0xA0 : 0x80;  // no overlong forms
    const unsigned char hi = b0 == 0xED ? 0x9F : 0xBF;  // no surrogates
    if (b1 < lo || b1 > hi || !is_continuation(byte(pos + 2))) return 0;
    out = (char32_t(b0 & 0x0F) << 12) | (char32_t(b1 & 0x3F) << 6) | (byte(pos + 2) & 0x3F);
    return 3;
  }
  if (b0 >= 0xF0 && b0 <= 0xF4) {
    if (left < 4) return 0;
    const unsigned char b1 = byte(pos + 1);
    const unsigned char lo = b0 == 0xF0 ? 0x90 : 0x80;  // no overlong forms
    const unsigned char hi = b0 == 0xF4 ? 0x8F : 0xBF;  // nothing above U+10FFFF
    if (b1 < lo || b1 > hi || !is_continuation(byte(pos + 2)) || !is_continuation(byte(pos + 3))) return 0;
    out = (char32_t(b0 & 0x07) << 18) | (char32_t(b1 & 0x3F) << 12) | (char32_t(byte(pos + 2) & 0x3F) << 6) |
          (byte(pos + 3) & 0x3F);
    return 4;
  }
  return 0;
}

}  // namespace

const char* unicode_version() { return tables::kUnicodeVersion; }

std::optional<size_t> find_invalid_utf8(std::string_view text) {
  size_t pos = 0;
  char32_t c = 0;
  while (pos < text.size()) {
    const size_t length = decode_one(text, pos, c);
    if (length == 0) return pos;
    pos += length;
  }
  return std::nullopt;
}

std::u32string decode_utf8(std::string_view text, std::string_view what) {
  std::u32string out;
  out.reserve(text.size());
  size_t pos = 0;
  char32_t c = 0;
  while (pos < text.size()) {
    const size_t length = decode_one(text, pos, c);
    if (length == 0) throw Error(std::string(what) + ": invalid UTF-8 at byte " + std::to_string(pos));
    out.push_back(c);
    pos += length;
  }
  return out;
}

void append_utf8(char32_t c, std::string& out) {
  if (c < 0x80) {
    out.push_back(static_cast<char>(c));
  } else if (c < 0x800) {
    out.push_back(static_cast<char>(0xC0 | (c >> 6)));
    out.push_back(static_cast<char>(0x80 | (c & 0x3F)));
  } else if (c < 0x10000) {
    out.push_back(static_cast<char>(0xE0 | (c >> 12)));
    out.push_back(static_cast<char>(0x80 | ((c >> 6) & 0x3F)));
    out.push_back(static_cast<char>(0x80 | (c & 0x3F)));
  } else {
    out.push_back(static_cast<char>(0xF0 | (c >> 18)));
    out.push_back(static_cast<char>(0x80 | ((c >> 12) & 0x3F)));
    out.push_back(static_cast<char>(0x80 | ((c >> 6) & 0x3F)));
    out.push_back(static_cast<char>(0x80 | (c & 0x3F)));
  }
}

std::string encode_utf8(std::u32string_view text) {
  std::string out;
  out.reserve(text.size());
  for (const char32_t c : text) append_utf8(c, out);
  return out;
}

size_t count_code_points(std::string_view utf8) {
  size_t count = 0;
  for (const char byte : utf8) count += is_continuation(static_cast<unsigned char>(byte)) ? 0 : 1;
  return count;
}

CharClass char_class(char32_t c) {
  const tables::ClassRange* range = find_range(tables::kClassRanges, tables::kClassRangeCount, c);
  if (range == nullptr) return CharClass::other;
  switch (range->value) {
    case tables::kWhitespace: return CharClass::whitespace;
    case tables::kControl: return CharClass::control;
    case tables::kPunctuation: return CharClass::punctuation;
    case tables::kNonspacingMark: return CharClass::nonspacing_mark;
    default: return CharClass::other;
  }
}

bool is_cjk_ideograph(char32_t c) {
  return (c >= 0x4E00 && c <= 0x9FFF) || (c >= 0x3400 && c <= 0x4DBF) || (c >= 0x20000 && c <= 0x2A6DF) ||
         (c >= 0x2A700 && c <= 0x2B73F) || (c >= 0x2B740 && c <= 0x2B81F) || (c >= 0x2B920 && c <= 0x2CEAF) ||
         (c >= 0xF900 && c <= 0xFAFF) || (c >= 0x2F800 && c <= 0x2FA1F);
}

uint8_t combining_class(char32_t c) {
  if (c < 0x300) return 0;
  const tables::CombiningRange* range = find_range(tables::kCombiningRanges, tables::kCombiningRangeCount, c);
  return range ? range->value : 0;
}

void append_decomposition(char32_t c, std::u32string& out) {
  if (c < 0xC0) {  // nothing below U+00C0 decomposes
    out.push_back(c);
    return;
  }
  if (c >= kHangulFirst && c <= kHangulLast) {
    const char32_t index = c - kHangulFirst;
    out.push_back(kHangulL + index / kHangulNCount);
    out.push_back(kHangulV + (index % kHangulNCount) / kHangulTCount);
    if (index % kHangulTCount != 0) out.push_back(kHangulT + index % kHangulTCount);
    return;
  }
  const tables::Mapping* mapping = find_mapping(tables::kDecompositions, tables::kDecompositionCount, c);
  if (mapping == nullptr) {
    out.push_back(c);
    return;
  }
  // Canonical decompositions nest a few levels at most (e.g. U+1E17 -> U+0113
  // U+0301 -> U+0065 U+0304 U+0301), so the recursion stays shallow.
  append_decomposition(mapping->first, out);
  if (mapping->second != 0) append_decomposition(mapping->second, out);
}

void canonical_order(std::u32string& text) {
  size_t i = 0;
  while (i < text.size()) {
    if (combining_class(text[i]) == 0) {
      ++i;
      continue;
    }
    size_t end = i + 1;
    while (end < text.size() && combining_class(text[end]) != 0) ++end;
    if (end - i > 1) {
      std::stable_sort(text.begin() + static_cast<std::ptrdiff_t>(i), text.begin() + static_cast<std::ptrdiff_t>(end),
                       [](char32_t a, char32_t b) { return combining_class(a) < combining_class(b); });
    }
    i = end;
  }
}

std::u32string nfd(std::u32string_view text) {
  std::u32string out;
  out.reserve(text.size());
  for (const char32_t c : text) append_decomposition(c, out);
  canonical_order(out);
  return out;
}

void append_lower(char32_t c, std::u32string& out) {
  if (c < 0x80) {
    out.push_back(c >= 'A' && c <= 'Z' ? c + ('a' - 'A') : c);
    return;
  }
  const tables::Mapping* mapping = find_mapping(tables::kLowerMappings, tables::kLowerMappingCount, c);
  if (mapping == nullptr) {
    out.push_back(c);
    return;
  }
  out.push_back(mapping->first);
  if (mapping->second != 0) out.push_back(mapping->second);
}

}  // namespace ardy::unicode
