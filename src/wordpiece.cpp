#include "wordpiece.hpp"

#include <algorithm>
#include <unordered_map>
#include <utility>

#include "io.hpp"
#include "unicode.hpp"

namespace ardy {
namespace {

// A vocabulary file is a few hundred KB; anything far beyond is not one.
constexpr size_t kMaxVocabBytes = size_t{64} << 20;

std::string quoted(std::string_view s) { return "'" + std::string(s) + "'"; }

}  // namespace

struct WordPieceTokenizer::Impl {
  std::string name;
  WordPieceOptions options;
  bool strip_accents = true;
  std::vector<std::string> tokens;  // id -> token; never resized once `ids` is built
  std::unordered_map<std::string_view, int64_t> ids;  // views into `tokens`
  size_t max_token_bytes = 0;
  int64_t unk = 0;
  int64_t cls = 0;
  int64_t sep = 0;
  int64_t pad = 0;

  int64_t lookup(std::string_view token) const {
    const auto it = ids.find(token);
    return it == ids.end() ? -1 : it->second;
  }

  std::vector<std::pair<std::string, int64_t>> specials;  // matched in the raw text, longest first

  // Step 0: splits the raw text into special tokens and the text between
  // them. Calls on_text(segment) and on_special(id, token) in order.
  template <typename OnText, typename OnSpecial>
  void split_specials(std::string_view text, OnText&& on_text, OnSpecial&& on_special) const;

  // Steps 1-5 of the header for text without special tokens: normalized
  // words, each as code points. The text must be valid UTF-8.
  std::vector<std::u32string> words(std::string_view text) const;

  void check_utf8(std::string_view text) const {
    if (const auto bad = unicode::find_invalid_utf8(text)) {
      throw Error(name + ": text: invalid UTF-8 at byte " + std::to_string(*bad));
    }
  }

  // Step 6 for one word: appends its pieces' ids (and, when `strings` is
  // given, the pieces themselves).
  void word_pieces(const std::u32string& word, std::vector<int64_t>& out, std::vector<std::string>* strings) const;

  std::vector<int64_t> piece_ids(std::string_view text, std::vector<std::string>* strings) const {
    check_utf8(text);
    std::vector<int64_t> out;
    split_specials(
        text,
        [&](std::string_view segment) {
          for (const std::u32string& word : words(segment)) word_pieces(word, out, strings);
        },
        [&](int64_t id, const std::string& token) {
          out.push_back(id);
          if (strings) strings->push_back(token);
        });
    return out;
  }
};

template <typename OnText, typename OnSpecial>
void WordPieceTokenizer::Impl::split_specials(std::string_view text, OnText&& on_text, OnSpecial&& on_special) const {
  // Leftmost-longest match on the raw bytes (special tokens are matched
  // before any normalization, case-sensitively, even inside words).
  size_t segment_start = 0;
  size_t pos = 0;
  while (pos < text.size()) {
    const std::pair<std::string, int64_t>* match = nullptr;
    for (const auto& special : specials) {  // longest first: the first hit is the longest
      if (text.compare(pos, special.first.size(), special.first) == 0) {
        match = &special;
        break;
      }
    }
    if (match == nullptr) {
      ++pos;
      continue;
    }
    if (pos > segment_start) on_text(text.substr(segment_start, pos - segment_start));
    on_special(match->second, match->first);
    pos += match->first.size();
    segment_start = pos;
  }
  if (segment_start < text.size()) on_text(text.substr(segment_start));
}

std::vector<std::u32string> WordPieceTokenizer::Impl::words(std::string_view text) const {
  const std::u32string decoded = unicode::decode_utf8(text, name + ": text");  // checked by the caller

  // 1-2: clean, isolate CJK ideographs.
  std::u32string cleaned;
  cleaned.reserve(decoded.size());
  for (const char32_t c : decoded) {
    if (c == 0 || c == 0xFFFD) continue;
    const unicode::CharClass cls_of_c = unicode::char_class(c);
    if (cls_of_c == unicode::CharClass::control) continue;
    if (cls_of_c == unicode::CharClass::whitespace) {
      cleaned.push_back(U' ');
    } else if (options.split_cjk_ideographs && unicode::is_cjk_ideograph(c)) {
      cleaned.push_back(U' ');
      cleaned.push_back(c);
      cleaned.push_back(U' ');
    } else {
      cleaned.push_back(c);
    }
  }

  // 3: strip accents.
  if (strip_accents) {
    std::u32string decomposed = unicode::nfd(cleaned);
    decomposed.erase(std::remove_if(decomposed.begin(), decomposed.end(),
                                    [](char32_t c) {
                                      return c >= 0x300 &&
                                             unicode::char_class(c) == unicode::CharClass::nonspacing_mark;
                                    }),
                     decomposed.end());
    cleaned = std::move(decomposed);
  }

  // 4: lower-case.
  if (options.lower_case) {
    std::u32string lowered;
    lowered.reserve(cleaned.size());
    for (const char32_t c : cleaned) unicode::append_lower(c, lowered);
    cleaned = std::move(lowered);
  }

  // 5: whitespace and punctuation split.
  std::vector<std::u32string> out;
  std::u32string current;
  const auto flush = [&] {
    if (!current.empty()) out.push_back(std::move(current));
    current.clear();
  };
  for (const char32_t c : cleaned) {
    const unicode::CharClass cls_of_c = unicode::char_class(c);
    if (cls_of_c == unicode::CharClass::whitespace) {
      flush();
    } else if (cls_of_c == unicode::CharClass::punctuation) {
      flush();
      out.emplace_back(1, c);
    } else {
      current.push_back(c);
    }
  }
  flush();
  return out;
}

void WordPieceTokenizer::Impl::word_pieces(const std::u32string& word, std::vector<int64_t>& out,
                                           std::vector<std::string>* strings) const {
  const auto unknown = [&] {
    out.push_back(unk);
    if (strings) strings->push_back(options.unk_token);
  };
  if (word.size() > options.max_chars_per_word) {
    unknown();
    return;
  }
  std::string utf8;
  std::vector<size_t> bounds;  // byte offset of each code point, then the end
  bounds.reserve(word.size() + 1);
  for (const char32_t c : word) {
    bounds.push_back(utf8.size());
    unicode::append_utf8(c, utf8);
  }
  bounds.push_back(utf8.size());

  const size_t first_piece = out.size();
  const size_t first_string = strings ? strings->size() : 0;
  const std::string& prefix = options.continuation_prefix;
  std::string candidate;
  size_t start = 0;
  while (start < word.size()) {
    int64_t found = -1;
    size_t end = word.size();
    for (; end > start; --end) {
      const size_t piece_bytes = bounds[end] - bounds[start];
      const std::string_view piece(utf8.data() + bounds[start], piece_bytes);
      if (start == 0) {
        if (piece_bytes > max_token_bytes) continue;  // longer than any vocabulary entry
        found = lookup(piece);
      } else {
        if (piece_bytes + prefix.size() > max_token_bytes) continue;
        candidate.assign(prefix);
        candidate.append(piece);
        found = lookup(candidate);
      }
      if (found >= 0) break;
    }
    if (found < 0) {
      // Greedy matching failed on the rest of the word: the whole word is [UNK].
      out.resize(first_piece);
      if (strings) strings->resize(first_string);
      unknown();
      return;
    }
    out.push_back(found);
    if (strings) strings->push_back(tokens[static_cast<size_t>(found)]);
    start = end;
  }
}

// ---------------------------------------------------------------------------

WordPieceTokenizer::WordPieceTokenizer(std::shared_ptr<const Impl> impl) : impl_(std::move(impl)) {}

WordPieceTokenizer WordPieceTokenizer::from_file(const std::string& path, WordPieceOptions options) {
  const std::string bytes = read_file(path, "a WordPiece vocabulary, vocab.txt", kMaxVocabBytes);
  return from_string(bytes, path, std::move(options));
}

WordPieceTokenizer WordPieceTokenizer::from_memory(const void* data, size_t size, const std::string& name,
                                                   WordPieceOptions options) {
  if (data == nullptr && size != 0) {
    throw Error(name + ": null vocabulary buffer of " + std::to_string(size) + " bytes");
  }
  const char* begin = static_cast<const char*>(data);
  return from_string(std::string_view(begin, size), name, std::move(options));
}

WordPieceTokenizer WordPieceTokenizer::from_string(std::string_view text, const std::string& name,
                                                   WordPieceOptions options) {
  if (options.max_tokens < 2) {
    throw Error(name + ": WordPieceOptions.max_tokens must be at least 2 ([CLS] and [SEP]), got " +
                std::to_string(options.max_tokens));
  }
  if (options.max_chars_per_word == 0) throw Error(name + ": WordPieceOptions.max_chars_per_word must be positive");
  if (text.empty()) throw Error(name + ": empty vocabulary (expected one token per line)");
  if (text.size() > kMaxVocabBytes) {
    throw Error(name + ": vocabulary of " + std::to_string(text.size()) + " bytes, larger than the " +
                std::to_string(kMaxVocabBytes) + " bytes allowed");
  }
  if (const auto bad = unicode::find_invalid_utf8(text)) {
    const size_t line = 1 + static_cast<size_t>(std::count(text.begin(), text.begin() + *bad, '\n'));
    throw Error(name + ": line " + std::to_string(line) + " is not valid UTF-8 (byte " + std::to_string(*bad) + ")");
  }

  auto impl = std::make_shared<Impl>();
  impl->name = name;
  impl->strip_accents = options.strip_accents.value_or(options.lower_case);
  options.strip_accents = impl->strip_accents;
  impl->options = std::move(options);

  // One token per line; "\r\n" endings accepted; no final newline needed.
  size_t pos = 0;
  while (pos < text.size()) {
    size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = text.substr(pos, end - pos);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (line.empty()) {
      throw Error(name + ": line " + std::to_string(impl->tokens.size() + 1) +
                  " is empty (expected one token per line)");
    }
    impl->tokens.emplace_back(line);
    pos = end + 1;
  }
  impl->ids.reserve(impl->tokens.size());
  for (size_t id = 0; id < impl->tokens.size(); ++id) {
    const std::string& token = impl->tokens[id];
    const auto [it, inserted] = impl->ids.emplace(token, static_cast<int64_t>(id));
    if (!inserted) {
      throw Error(name + ": token " + quoted(token) + " appears twice (lines " + std::to_string(it->second + 1) +
                  " and " + std::to_string(id + 1) + ")");
    }
    impl->max_token_bytes = std::max(impl->max_token_bytes, token.size());
  }

  const auto special = [&](const std::string& token, const char* option) {
    const int64_t id = impl->lookup(token);
    if (id < 0) {
      throw Error(name + ": the vocabulary has no " + quoted(token) + " token (WordPieceOptions." + option + ")");
    }
    return id;
  };
  impl->unk = special(impl->options.unk_token, "unk_token");
  impl->cls = special(impl->options.cls_token, "cls_token");
  impl->sep = special(impl->options.sep_token, "sep_token");
  impl->pad = special(impl->options.pad_token, "pad_token");
  for (const std::string& token : impl->options.special_tokens) {
    if (token.empty()) throw Error(name + ": WordPieceOptions.special_tokens holds an empty token");
    const int64_t id = special(token, "special_tokens");
    if (std::none_of(impl->specials.begin(), impl->specials.end(), [&](const auto& s) { return s.first == token; })) {
      impl->specials.emplace_back(token, id);
    }
  }
  std::stable_sort(impl->specials.begin(), impl->specials.end(),
                   [](const auto& a, const auto& b) { return a.first.size() > b.first.size(); });
  return WordPieceTokenizer(std::move(impl));
}

const std::string& WordPieceTokenizer::name() const { return impl_->name; }
const WordPieceOptions& WordPieceTokenizer::options() const { return impl_->options; }
size_t WordPieceTokenizer::vocab_size() const { return impl_->tokens.size(); }

std::optional<int64_t> WordPieceTokenizer::find_token(std::string_view token) const {
  const int64_t id = impl_->lookup(token);
  return id < 0 ? std::nullopt : std::optional<int64_t>(id);
}

const std::string& WordPieceTokenizer::token(int64_t id) const {
  if (id < 0 || static_cast<uint64_t>(id) >= impl_->tokens.size()) {
    throw Error(impl_->name + ": token id " + std::to_string(id) + " out of range (the vocabulary has " +
                std::to_string(impl_->tokens.size()) + " tokens)");
  }
  return impl_->tokens[static_cast<size_t>(id)];
}

int64_t WordPieceTokenizer::unk_id() const { return impl_->unk; }
int64_t WordPieceTokenizer::cls_id() const { return impl_->cls; }
int64_t WordPieceTokenizer::sep_id() const { return impl_->sep; }
int64_t WordPieceTokenizer::pad_id() const { return impl_->pad; }

std::vector<std::string> WordPieceTokenizer::basic_tokenize(std::string_view text) const {
  impl_->check_utf8(text);
  std::vector<std::string> out;
  impl_->split_specials(
      text,
      [&](std::string_view segment) {
        for (const std::u32string& word : impl_->words(segment)) out.push_back(unicode::encode_utf8(word));
      },
      [&](int64_t, const std::string& token) { out.push_back(token); });
  return out;
}

std::string WordPieceTokenizer::normalize(std::string_view text) const {
  std::string out;
  for (const std::string& word : basic_tokenize(text)) {
    if (!out.empty()) out.push_back(' ');
    out += word;
  }
  return out;
}

std::vector<std::string> WordPieceTokenizer::tokenize(std::string_view text) const {
  std::vector<std::string> strings;
  impl_->piece_ids(text, &strings);
  return strings;
}

WordPieceEncoding WordPieceTokenizer::encode(std::string_view text) const {
  return encode(text, impl_->options.max_tokens);
}

WordPieceEncoding WordPieceTokenizer::encode(std::string_view text, size_t max_tokens) const {
  if (max_tokens < 2) {
    throw Error(impl_->name + ": max_tokens must be at least 2 ([CLS] and [SEP]), got " + std::to_string(max_tokens));
  }
  std::vector<int64_t> pieces = impl_->piece_ids(text, nullptr);
  WordPieceEncoding encoding;
  if (pieces.size() > max_tokens - 2) {
    pieces.resize(max_tokens - 2);
    encoding.truncated = true;
  }
  encoding.input_ids.reserve(pieces.size() + 2);
  encoding.input_ids.push_back(impl_->cls);
  encoding.input_ids.insert(encoding.input_ids.end(), pieces.begin(), pieces.end());
  encoding.input_ids.push_back(impl_->sep);
  encoding.attention_mask.assign(encoding.input_ids.size(), 1);
  return encoding;
}

}  // namespace ardy
