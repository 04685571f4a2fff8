#pragma once

// Prompt -> sentence embedding: the WordPiece tokenizer, the encoder graph
// (text_encoder.onnx: int64 input_ids and attention_mask [batch, tokens] ->
// float32 embedding [batch, D], pooling and L2 normalization inside the
// graph), and an LRU cache keyed by the normalized prompt, so a prompt the
// planner asks for again costs a tokenizer pass and a copy.
//
// Thread-safe: encode() may be called from several threads at once (the
// cache has its own lock; inference runs outside it).

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "error.hpp"
#include "onnx_session.hpp"
#include "wordpiece.hpp"

namespace ardy {

struct TextEncoderOptions {
  size_t cache_capacity = 256;     // prompts kept; 0 turns the cache off
  size_t max_prompt_chars = 2000;  // longer prompts (in code points) are refused
  // Graph signature. token_type_ids is fed zeros when the graph has it.
  std::string input_ids_name = "input_ids";
  std::string attention_mask_name = "attention_mask";
  std::string token_type_ids_name = "token_type_ids";
  std::string embedding_name = "embedding";
};

struct TextCacheStats {
  uint64_t hits = 0;
  uint64_t misses = 0;
  size_t size = 0;  // prompts cached now
  size_t capacity = 0;
};

class TextEncoder {
 public:
  // Checks the graph: the two int64 inputs of rank 2, no other input but an
  // optional token_type_ids, and a float32 output [batch, D] with a fixed
  // D > 0. Throws Error naming the graph and the field.
  TextEncoder(WordPieceTokenizer tokenizer, OnnxSession session, TextEncoderOptions options = {});
  ~TextEncoder();
  TextEncoder(TextEncoder&&) noexcept;
  TextEncoder& operator=(TextEncoder&&) noexcept;
  TextEncoder(const TextEncoder&) = delete;
  TextEncoder& operator=(const TextEncoder&) = delete;

  size_t embedding_size() const;  // D
  const WordPieceTokenizer& tokenizer() const;
  const OnnxSession& session() const;
  const TextEncoderOptions& options() const;

  // The cache key of a prompt: its normalized form (WordPieceTokenizer::
  // normalize). Throws Error "prompt is not valid UTF-8 (byte N)", "prompt
  // is 10000 characters long; the limit is 2000 ...", or "prompt is empty"
  // (nothing but whitespace and control characters).
  std::string normalize_prompt(std::string_view prompt) const;

  // The embedding of one prompt (D floats), from the cache when it is there.
  std::vector<float> encode(std::string_view prompt) const;
  // Several prompts: cached ones from the cache, the others in one batched
  // graph call (padded with [PAD], mask 0). Validates every prompt first.
  std::vector<std::vector<float>> encode_batch(const std::vector<std::string>& prompts) const;

  TextCacheStats cache_stats() const;
  // Empties the cache and zeroes the hit and miss counts.
  void clear_cache() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ardy
