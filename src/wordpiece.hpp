#pragma once

// BERT's uncased WordPiece tokenizer, written to give the same ids as the
// HuggingFace tokenizer of all-MiniLM-L6-v2 (tokenizers' BertNormalizer +
// BertPreTokenizer + WordPiece + the [CLS] ... [SEP] template):
//
// 1. clean: drop NUL, U+FFFD and control characters (Cc, Cf, Co, Cs; tab,
//    line feed and carriage return count as whitespace); whitespace -> ' ';
// 2. CJK ideographs get a space on each side (each becomes its own word);
// 3. strip accents: NFD, then drop nonspacing marks (Mn);
// 4. lower-case (per code point, full mappings);
// 5. split on whitespace, and split off every punctuation character as its
//    own word (Unicode P* and the ASCII symbol ranges);
// 6. WordPiece per word: greedy longest match first, "##" on continuation
//    pieces; a word with an unmatchable rest, or longer than 100 code
//    points, becomes [UNK];
// 7. [CLS] + pieces + [SEP], the pieces truncated so the whole fits
//    max_tokens.
//
// Before step 1, special tokens written in the text ("[SEP]", "[MASK]", ...)
// are split off verbatim and keep their ids; the text between them goes
// through steps 1-6 on its own.
//
// The vocabulary is vocab.txt: one token per line, the id is the line number
// (from 0). Loaded from a file or from bytes an engine read itself.
// Tokenizers are immutable once built; copies share the vocabulary, and every
// method may be called from several threads at once.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "error.hpp"

namespace ardy {

struct WordPieceOptions {
  bool lower_case = true;
  // NFD + removal of nonspacing marks. Unset: follows lower_case (BERT's rule).
  std::optional<bool> strip_accents;
  bool split_cjk_ideographs = true;
  // [CLS] + pieces + [SEP] never exceeds this (at least 2). 128 is what
  // export_tools embeds the training sentences with; the model package's
  // text settings give the value a model was trained with.
  size_t max_tokens = 128;
  size_t max_chars_per_word = 100;  // longer words (in code points) become [UNK]
  std::string unk_token = "[UNK]";
  std::string cls_token = "[CLS]";
  std::string sep_token = "[SEP]";
  std::string pad_token = "[PAD]";
  std::string continuation_prefix = "##";
  // Matched in the raw text before normalization (exact bytes, even inside
  // words, longest first) and emitted as their own ids, as HuggingFace does
  // with its added special tokens. Each must be in the vocabulary.
  std::vector<std::string> special_tokens = {"[PAD]", "[UNK]", "[CLS]", "[SEP]", "[MASK]"};
};

// One encoded text: [CLS] pieces [SEP], ids and a mask of ones (the same
// length). Batches pad with [PAD] and mask 0 (TextEncoder does that).
struct WordPieceEncoding {
  std::vector<int64_t> input_ids;
  std::vector<int64_t> attention_mask;
  bool truncated = false;  // pieces were dropped to fit max_tokens
};

class WordPieceTokenizer {
 public:
  // Reads vocab.txt. `path` names the vocabulary in every error message.
  static WordPieceTokenizer from_file(const std::string& path, WordPieceOptions options = {});
  // Parses vocabulary bytes (e.g. read by an engine from a packed archive);
  // they need not outlive the call. `name` names the vocabulary in errors.
  static WordPieceTokenizer from_memory(const void* data, size_t size, const std::string& name,
                                        WordPieceOptions options = {});
  static WordPieceTokenizer from_string(std::string_view vocab_text, const std::string& name,
                                        WordPieceOptions options = {});

  const std::string& name() const;
  const WordPieceOptions& options() const;  // strip_accents resolved (always set)
  size_t vocab_size() const;

  // Id of a token (exact vocabulary entry), nullopt when absent.
  std::optional<int64_t> find_token(std::string_view token) const;
  // Token of an id; throws Error when the id is out of range.
  const std::string& token(int64_t id) const;
  int64_t unk_id() const;
  int64_t cls_id() const;
  int64_t sep_id() const;
  int64_t pad_id() const;

  // Steps 1-5: the words WordPiece sees, as UTF-8 (special tokens verbatim).
  // Throws Error on invalid UTF-8 ("<name>: text: invalid UTF-8 at byte N").
  std::vector<std::string> basic_tokenize(std::string_view text) const;
  // The words of basic_tokenize joined by single spaces: two texts with the
  // same normalized form encode to the same ids (normalized words never hold
  // punctuation next to other characters, so they cannot spell a bracketed
  // special token).
  std::string normalize(std::string_view text) const;
  // Steps 1-6: word pieces as strings, without [CLS] and [SEP], not truncated.
  std::vector<std::string> tokenize(std::string_view text) const;
  // Steps 1-7 with options().max_tokens, or with the given max_tokens (>= 2).
  WordPieceEncoding encode(std::string_view text) const;
  WordPieceEncoding encode(std::string_view text, size_t max_tokens) const;

 private:
  struct Impl;
  explicit WordPieceTokenizer(std::shared_ptr<const Impl> impl);
  std::shared_ptr<const Impl> impl_;
};

}  // namespace ardy
