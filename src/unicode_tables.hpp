#pragma once

// Declarations of the generated Unicode tables (unicode_tables.gen.cpp, written
// by tools/gen_unicode_tables.py from Python's unicodedata). Internal to the
// runtime: use unicode.hpp, which wraps them in lookups.

#include <cstddef>
#include <cstdint>

namespace ardy::unicode_tables {

// Character classes of the BERT normalizer (values of ClassRange::value).
// Code points in no range are "other".
inline constexpr uint8_t kWhitespace = 1;      // Zs, Zl, Zp, tab, line feed, carriage return
inline constexpr uint8_t kControl = 2;         // Cc, Cf, Co, Cs but not the three whitespace controls
inline constexpr uint8_t kPunctuation = 3;     // P*, and ASCII 33-47, 58-64, 91-96, 123-126
inline constexpr uint8_t kNonspacingMark = 4;  // Mn

struct ClassRange {
  char32_t first;
  char32_t last;  // inclusive
  uint8_t value;
};

// Non-zero canonical combining classes.
struct CombiningRange {
  char32_t first;
  char32_t last;  // inclusive
  uint8_t value;
};

// code_point -> first (+ second when non-zero). Sorted by code_point.
struct Mapping {
  char32_t code_point;
  char32_t first;
  char32_t second;
};

extern const char kUnicodeVersion[];

// All sorted by first code point, non-overlapping.
extern const ClassRange kClassRanges[];
extern const size_t kClassRangeCount;
extern const CombiningRange kCombiningRanges[];
extern const size_t kCombiningRangeCount;

// Canonical decompositions, one level (a mapped code point may map again).
// Hangul syllables (U+AC00..U+D7A3) are decomposed algorithmically, not here.
extern const Mapping kDecompositions[];
extern const size_t kDecompositionCount;

// Lower case of single code points (full mappings: U+0130 -> U+0069 U+0307).
extern const Mapping kLowerMappings[];
extern const size_t kLowerMappingCount;

}  // namespace ardy::unicode_tables
