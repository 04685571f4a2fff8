// WordPiece tokenization and the Unicode primitives under it
// (src/wordpiece.hpp, src/unicode.hpp), with the BERT vocabulary of
// tests/data/text/vocab.txt. The first byte picks the tokenizer options
// (casing, accents, CJK splitting, a small max_tokens) and whether the rest
// is a prompt or a whole vocabulary file. Checked: invalid UTF-8 is an
// ardy::Error; for valid UTF-8, decode/encode round-trips, NFD is stable and
// an encoding has 2..max_tokens ids, one mask entry each, and the
// normalized text encodes the same.

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "fuzz_common.hpp"
#include "unicode.hpp"
#include "wordpiece.hpp"

namespace {

ardy::WordPieceOptions options_for(uint8_t selector) {
  ardy::WordPieceOptions o;
  o.lower_case = selector & 1;
  if (selector & 2) o.strip_accents = (selector & 4) != 0;
  o.split_cjk_ideographs = (selector & 8) == 0;
  o.max_tokens = (selector & 16) ? 8 : 128;
  o.max_chars_per_word = (selector & 32) ? 5 : 100;
  return o;
}

const std::vector<ardy::WordPieceTokenizer>& tokenizers() {
  static const std::vector<ardy::WordPieceTokenizer> all = [] {
    const std::string vocab = ardy_fuzz::read_bytes(ardy_fuzz::data_path("text/vocab.txt"));
    std::vector<ardy::WordPieceTokenizer> out;
    for (int s = 0; s < 64; ++s) {
      out.push_back(ardy::WordPieceTokenizer::from_string(vocab, "vocab.txt", options_for(uint8_t(s))));
    }
    return out;
  }();
  return all;
}

void check_unicode(std::string_view text) {
  namespace u = ardy::unicode;
  const auto invalid = u::find_invalid_utf8(text);
  if (invalid) {
    try {
      u::decode_utf8(text, "fuzz");
    } catch (const ardy::Error&) {
      return;
    }
    ardy_fuzz::broken("decode_utf8 accepted text find_invalid_utf8 refuses");
  }
  const std::u32string decoded = u::decode_utf8(text, "fuzz");
  if (u::encode_utf8(decoded) != text) ardy_fuzz::broken("UTF-8 decode/encode does not round-trip");
  if (u::count_code_points(text) != decoded.size()) ardy_fuzz::broken("count_code_points disagrees with decode_utf8");
  const std::u32string once = u::nfd(decoded);
  if (u::nfd(once) != once) ardy_fuzz::broken("NFD is not idempotent");
  std::u32string lower;
  for (char32_t c : decoded) {
    u::char_class(c);
    u::is_cjk_ideograph(c);
    u::combining_class(c);
    u::append_lower(c, lower);
  }
  if (u::find_invalid_utf8(u::encode_utf8(lower))) ardy_fuzz::broken("lower case gave invalid UTF-8");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const uint8_t selector = data[0];
  const std::string_view text(reinterpret_cast<const char*>(data + 1), size - 1);
  if (selector & 0x80) {
    // The rest is a vocabulary file.
    ardy_fuzz::refusals_allowed([&] {
      const auto t = ardy::WordPieceTokenizer::from_memory(text.data(), text.size(), "fuzz_vocab.txt",
                                                           options_for(selector & 63));
      const ardy::WordPieceEncoding e = t.encode("a person walks [MASK] forward");
      if (e.input_ids.size() < 2 || e.input_ids.size() > t.options().max_tokens) {
        ardy_fuzz::broken("encoding of the wrong length");
      }
      for (int64_t id : e.input_ids) t.token(id);
    });
    return 0;
  }
  check_unicode(text);
  const ardy::WordPieceTokenizer& t = tokenizers()[selector & 63];
  ardy_fuzz::refusals_allowed([&] {
    const std::string normalized = t.normalize(text);
    for (const std::string& piece : t.tokenize(text)) {
      if (!t.find_token(piece)) ardy_fuzz::broken("tokenize gave a piece outside the vocabulary: " + piece);
    }
    const ardy::WordPieceEncoding e = t.encode(text);
    if (e.input_ids.size() < 2 || e.input_ids.size() > t.options().max_tokens ||
        e.attention_mask.size() != e.input_ids.size()) {
      ardy_fuzz::broken("encoding of the wrong length");
    }
    // wordpiece.hpp: texts with the same normalized form encode the same.
    if (t.encode(normalized).input_ids != e.input_ids) ardy_fuzz::broken("normalize changed the encoding");
    for (int64_t id : e.input_ids) t.token(id);
  });
  return 0;
}
