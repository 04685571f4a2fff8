#pragma once

// The Unicode primitives the WordPiece tokenizer is built from: strict UTF-8
// decoding and encoding, the BERT normalizer's character classes, canonical
// decomposition (NFD), and lower-casing. Data: unicode_tables.gen.cpp
// (generated from Python's unicodedata; unicode_version() says which Unicode).

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace ardy::unicode {

// The Unicode version of the tables, e.g. "14.0.0".
const char* unicode_version();

// --- UTF-8 -----------------------------------------------------------------

// Byte offset of the first ill-formed sequence (overlong forms, surrogates,
// code points above U+10FFFF, stray or missing continuation bytes), or
// nullopt when the whole text is well-formed UTF-8.
std::optional<size_t> find_invalid_utf8(std::string_view text);

// Decodes well-formed UTF-8. Throws ardy::Error "<what>: invalid UTF-8 at
// byte N" otherwise.
std::u32string decode_utf8(std::string_view text, std::string_view what);

// Appends the UTF-8 form of one code point (must be a scalar value).
void append_utf8(char32_t code_point, std::string& out);
std::string encode_utf8(std::u32string_view text);

// Number of code points in well-formed UTF-8 (continuation bytes not counted).
size_t count_code_points(std::string_view utf8);

// --- character classes -----------------------------------------------------

enum class CharClass : uint8_t {
  other,
  whitespace,       // Zs, Zl, Zp, '\t', '\n', '\r'
  control,          // Cc, Cf, Co, Cs except '\t', '\n', '\r' (unassigned code points are "other")
  punctuation,      // any P* category, and ASCII 33-47, 58-64, 91-96, 123-126 ("$", "+", "^", ...)
  nonspacing_mark,  // Mn: what accent stripping removes
};

CharClass char_class(char32_t c);

// CJK Unified Ideographs (and extensions A-E, compatibility ideographs), the
// ranges BERT isolates as single tokens. Hiragana, Katakana and Hangul are not.
// The ranges are HuggingFace tokenizers' (extension E from U+2B920, where
// BERT's original Python starts at U+2B820), so ids match training's.
bool is_cjk_ideograph(char32_t c);

// Canonical combining class (0 for starters and unassigned code points).
uint8_t combining_class(char32_t c);

// --- normalization ---------------------------------------------------------

// Full canonical decomposition of one code point (recursive, Hangul
// algorithmic), appended without reordering.
void append_decomposition(char32_t c, std::u32string& out);

// Canonical ordering: stable sort by combining class within every run of
// non-starters.
void canonical_order(std::u32string& text);

// NFD = full decomposition + canonical ordering.
std::u32string nfd(std::u32string_view text);

// Lower case of one code point (one or two code points), appended.
void append_lower(char32_t c, std::u32string& out);

}  // namespace ardy::unicode
