// unicode: strict UTF-8, character classes, NFD with canonical ordering,
// lower-casing; the data comes from the generated tables.

#include <catch_amalgamated.hpp>

#include <string>

#include "support/error_message.hpp"
#include "unicode.hpp"

using Catch::Matchers::ContainsSubstring;
namespace u = ardy::unicode;

TEST_CASE("UTF-8 decoding accepts well-formed text and round-trips", "[unicode]") {
  const std::string text = "a\xC3\xA9\xE2\x82\xAC\xF0\x9F\x98\x80z";  // a é € 😀 z
  const std::u32string decoded = u::decode_utf8(text, "test");
  CHECK(decoded == std::u32string{U'a', 0xE9, 0x20AC, 0x1F600, U'z'});
  CHECK(u::encode_utf8(decoded) == text);
  CHECK(u::count_code_points(text) == 5);
  CHECK_FALSE(u::find_invalid_utf8(text).has_value());
  CHECK(u::decode_utf8("", "test").empty());
  // Boundaries of each sequence length.
  const std::u32string edges{0x7F, 0x80, 0x7FF, 0x800, 0xD7FF, 0xE000, 0xFFFF, 0x10000, 0x10FFFF};
  CHECK(u::decode_utf8(u::encode_utf8(edges), "edges") == edges);
}

TEST_CASE("UTF-8 decoding refuses ill-formed sequences with their byte offset", "[unicode]") {
  struct Bad {
    std::string bytes;
    size_t offset;
  };
  const Bad cases[] = {
      {"ab\x80", 2},                // stray continuation byte
      {"a\xC0\x80", 1},             // overlong NUL
      {"\xC1\xBF", 0},              // overlong
      {"xy\xE0\x80\x80", 2},        // overlong 3-byte
      {"\xED\xA0\x80", 0},          // UTF-16 surrogate
      {"\xF4\x90\x80\x80", 0},      // above U+10FFFF
      {"\xF5\x80\x80\x80", 0},      // invalid lead byte
      {"ok\xE2\x82", 2},            // truncated at the end
      {"\xC3(", 0},                 // missing continuation
      {"\xF0\x9F\x98", 0},          // truncated 4-byte
      {std::string("a\xFF", 2), 1}, // never valid
  };
  for (const Bad& bad : cases) {
    CAPTURE(bad.bytes);
    REQUIRE(u::find_invalid_utf8(bad.bytes).has_value());
    CHECK(*u::find_invalid_utf8(bad.bytes) == bad.offset);
    CHECK_THAT(ardy_test::error_message([&] { u::decode_utf8(bad.bytes, "prompt"); }),
               ContainsSubstring("prompt: invalid UTF-8 at byte " + std::to_string(bad.offset)));
  }
}

TEST_CASE("character classes follow the BERT normalizer", "[unicode]") {
  using C = u::CharClass;
  CHECK(u::char_class(U' ') == C::whitespace);
  CHECK(u::char_class(U'\t') == C::whitespace);
  CHECK(u::char_class(U'\n') == C::whitespace);
  CHECK(u::char_class(U'\r') == C::whitespace);
  CHECK(u::char_class(0xA0) == C::whitespace);    // no-break space (Zs)
  CHECK(u::char_class(0x3000) == C::whitespace);  // ideographic space
  CHECK(u::char_class(0x2028) == C::whitespace);  // line separator (Zl)
  CHECK(u::char_class(0x0B) == C::control);       // vertical tab: Cc, not one of the three
  CHECK(u::char_class(0x85) == C::control);
  CHECK(u::char_class(0x200B) == C::control);  // zero width space (Cf)
  CHECK(u::char_class(0xAD) == C::control);    // soft hyphen (Cf)
  CHECK(u::char_class(0xE000) == C::control);  // private use (Co)
  CHECK(u::char_class(0x0378) == C::other);    // unassigned: kept, as HuggingFace tokenizers does
  for (char32_t c : {U'!', U'$', U'+', U'<', U'=', U'>', U'^', U'`', U'|', U'~', U'@', U'[', U'{'}) {
    CAPTURE(static_cast<uint32_t>(c));
    CHECK(u::char_class(c) == C::punctuation);
  }
  CHECK(u::char_class(0x2014) == C::punctuation);  // em dash (Pd)
  CHECK(u::char_class(0x201C) == C::punctuation);  // left double quotation mark (Pi)
  CHECK(u::char_class(0x3002) == C::punctuation);  // ideographic full stop
  CHECK(u::char_class(0x20AC) == C::other);        // euro sign (Sc): not punctuation
  CHECK(u::char_class(0x1F600) == C::other);       // emoji (So)
  CHECK(u::char_class(0x0301) == C::nonspacing_mark);
  CHECK(u::char_class(0xFE0F) == C::nonspacing_mark);  // variation selector
  CHECK(u::char_class(U'a') == C::other);
  CHECK(u::char_class(0x10FFFF) == C::other);
  // Overrides where tokenizers' older tables differ from Unicode 14:
  CHECK(u::char_class(0x0890) == C::other);  // Cf since Unicode 14, unassigned there
  CHECK(u::char_class(0x061D) == C::other);  // Po since Unicode 14
  CHECK(std::string(u::unicode_version()) == "14.0.0");
}

TEST_CASE("CJK ideographs are the ranges HuggingFace tokenizers isolates", "[unicode]") {
  CHECK(u::is_cjk_ideograph(0x4E00));
  CHECK(u::is_cjk_ideograph(0x9FFF));
  CHECK(u::is_cjk_ideograph(0x3400));
  CHECK(u::is_cjk_ideograph(0x20000));
  CHECK(u::is_cjk_ideograph(0xF900));
  CHECK(u::is_cjk_ideograph(0x2B920));
  CHECK_FALSE(u::is_cjk_ideograph(0x2B820));  // BERT's Python has it; tokenizers does not
  CHECK_FALSE(u::is_cjk_ideograph(0x3042));   // hiragana
  CHECK_FALSE(u::is_cjk_ideograph(0x30AB));   // katakana
  CHECK_FALSE(u::is_cjk_ideograph(0xAC00));   // hangul
}

TEST_CASE("NFD decomposes fully, Hangul algorithmically, and orders marks canonically", "[unicode]") {
  CHECK(u::nfd(U"\u00E9") == U"e\u0301");
  CHECK(u::nfd(U"\u1E17") == U"e\u0304\u0301");          // two levels of decomposition
  CHECK(u::nfd(U"\u01D5") == U"U\u0308\u0304");
  CHECK(u::nfd(U"\u0344") == U"\u0308\u0301");           // a mark that decomposes into two
  CHECK(u::nfd(U"\u037E") == U";");                      // singleton: Greek question mark
  CHECK(u::nfd(U"\uF900") == U"\u8C48");                 // CJK compatibility ideograph
  CHECK(u::nfd(U"\uD55C") == U"\u1112\u1161\u11AB");     // 한: L V T
  CHECK(u::nfd(U"\uAC00") == U"\u1100\u1161");           // 가: L V
  CHECK(u::nfd(U"a\u0301\u0328") == U"a\u0328\u0301");   // ccc 230 after ccc 202
  CHECK(u::nfd(U"\u0105\u0301") == U"a\u0328\u0301");
  CHECK(u::nfd(U"a\u0301b\u0328") == U"a\u0301b\u0328");  // runs end at starters
  CHECK(u::nfd(U"\uFB01") == U"\uFB01");                  // compatibility only: unchanged
  CHECK(u::nfd(U"plain ascii") == U"plain ascii");
  CHECK(u::combining_class(0x0301) == 230);
  CHECK(u::combining_class(0x0328) == 202);
  CHECK(u::combining_class(U'a') == 0);
}

TEST_CASE("lower-casing maps code points, with full mappings", "[unicode]") {
  const auto lower = [](std::u32string_view text) {
    std::u32string out;
    for (const char32_t c : text) u::append_lower(c, out);
    return out;
  };
  CHECK(lower(U"Hello WORLD 123") == U"hello world 123");
  CHECK(lower(U"\u00C9\u00C5\u00D8") == U"\u00E9\u00E5\u00F8");
  CHECK(lower(U"\u0130") == U"i\u0307");                 // İ: two code points
  CHECK(lower(U"\u03A3") == U"\u03C3");                  // capital sigma: no final-sigma context
  CHECK(lower(U"\u0416\u0419") == U"\u0436\u0439");      // Cyrillic
  CHECK(lower(U"\u1E9E") == U"\u00DF");                  // capital sharp s
  CHECK(lower(U"\uFF21") == U"\uFF41");                  // full-width A
  CHECK(lower(U"\u01C5") == U"\u01C6");                  // title case Dž
  CHECK(lower(U"\u00DF\u4E00") == U"\u00DF\u4E00");
}
