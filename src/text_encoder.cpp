#include "text_encoder.hpp"

#include <algorithm>
#include <cmath>
#include <list>
#include <mutex>
#include <unordered_map>
#include <utility>

#include "unicode.hpp"

namespace ardy {

struct TextEncoder::Impl {
  WordPieceTokenizer tokenizer;
  OnnxSession session;
  TextEncoderOptions options;
  size_t embedding_size = 0;
  bool has_token_type_ids = false;

  // LRU: most recently used at the front; the map points into the list.
  using Entry = std::pair<std::string, std::vector<float>>;
  mutable std::mutex mutex;
  mutable std::list<Entry> entries;
  mutable std::unordered_map<std::string, std::list<Entry>::iterator> index;
  mutable uint64_t hits = 0;
  mutable uint64_t misses = 0;

  Impl(WordPieceTokenizer t, OnnxSession s, TextEncoderOptions o)
      : tokenizer(std::move(t)), session(std::move(s)), options(std::move(o)) {}

  void check_graph();

  // Cached embedding copied into `out`; false on a miss. Counts either way.
  bool lookup(const std::string& key, std::vector<float>& out) const {
    std::lock_guard<std::mutex> lock(mutex);
    const auto it = index.find(key);
    if (it == index.end()) {
      ++misses;
      return false;
    }
    ++hits;
    entries.splice(entries.begin(), entries, it->second);
    out = it->second->second;
    return true;
  }

  void insert(const std::string& key, const std::vector<float>& embedding) const {
    if (options.cache_capacity == 0) return;
    std::lock_guard<std::mutex> lock(mutex);
    const auto it = index.find(key);
    if (it != index.end()) {  // another thread got there first
      entries.splice(entries.begin(), entries, it->second);
      return;
    }
    entries.emplace_front(key, embedding);
    index.emplace(key, entries.begin());
    while (entries.size() > options.cache_capacity) {
      index.erase(entries.back().first);
      entries.pop_back();
    }
  }

  // One graph call over the given prompts (already validated).
  std::vector<std::vector<float>> run(const std::vector<std::string_view>& prompts) const;
};

void TextEncoder::Impl::check_graph() {
  const std::string& name = session.name();
  const auto check_int_input = [&](const std::string& input) {
    const TensorInfo* info = session.find_input(input);
    if (info == nullptr) {
      throw Error(name + ": the text encoder graph has no input '" + input + "' (TextEncoderOptions)");
    }
    if (info->dtype != "int64" || info->shape.size() != 2) {
      throw Error(name + ": input '" + input + "' must be int64 [batch, tokens], the graph has " + info->dtype +
                  " of rank " + std::to_string(info->shape.size()));
    }
  };
  check_int_input(options.input_ids_name);
  check_int_input(options.attention_mask_name);
  has_token_type_ids = session.find_input(options.token_type_ids_name) != nullptr;
  if (has_token_type_ids) check_int_input(options.token_type_ids_name);
  for (const TensorInfo& input : session.inputs()) {
    if (input.name != options.input_ids_name && input.name != options.attention_mask_name &&
        input.name != options.token_type_ids_name) {
      throw Error(name + ": unexpected input '" + input.name + "' (a text encoder takes '" + options.input_ids_name +
                  "', '" + options.attention_mask_name + "' and optionally '" + options.token_type_ids_name + "')");
    }
  }
  const TensorInfo* output = session.find_output(options.embedding_name);
  if (output == nullptr) {
    throw Error(name + ": the text encoder graph has no output '" + options.embedding_name + "' (TextEncoderOptions)");
  }
  if (output->dtype != "float32" || output->shape.size() != 2 || output->shape[1] <= 0) {
    throw Error(name + ": output '" + options.embedding_name +
                "' must be float32 [batch, D] with a fixed D, the graph has " + output->dtype + " of rank " +
                std::to_string(output->shape.size()));
  }
  embedding_size = static_cast<size_t>(output->shape[1]);
}

std::vector<std::vector<float>> TextEncoder::Impl::run(const std::vector<std::string_view>& prompts) const {
  std::vector<WordPieceEncoding> encodings;
  encodings.reserve(prompts.size());
  size_t length = 0;
  for (const std::string_view prompt : prompts) {
    encodings.push_back(tokenizer.encode(prompt));
    length = std::max(length, encodings.back().input_ids.size());
  }
  const size_t batch = prompts.size();
  std::vector<int64_t> ids(batch * length, tokenizer.pad_id());
  std::vector<int64_t> mask(batch * length, 0);
  for (size_t b = 0; b < batch; ++b) {
    std::copy(encodings[b].input_ids.begin(), encodings[b].input_ids.end(), ids.begin() + b * length);
    std::copy(encodings[b].attention_mask.begin(), encodings[b].attention_mask.end(), mask.begin() + b * length);
  }
  const std::vector<int64_t> shape{static_cast<int64_t>(batch), static_cast<int64_t>(length)};
  std::vector<std::pair<std::string, Tensor>> inputs;
  inputs.emplace_back(options.input_ids_name, Tensor::int64(shape, std::move(ids)));
  inputs.emplace_back(options.attention_mask_name, Tensor::int64(shape, std::move(mask)));
  if (has_token_type_ids) {
    inputs.emplace_back(options.token_type_ids_name, Tensor::int64(shape, std::vector<int64_t>(batch * length, 0)));
  }
  const std::vector<Tensor> outputs = session.run(inputs, {options.embedding_name});
  const Tensor& out = outputs.at(0);
  if (out.shape != std::vector<int64_t>{static_cast<int64_t>(batch), static_cast<int64_t>(embedding_size)}) {
    throw Error(session.name() + ": output '" + options.embedding_name + "' has an unexpected shape for a batch of " +
                std::to_string(batch));
  }
  std::vector<std::vector<float>> result(batch);
  for (size_t b = 0; b < batch; ++b) {
    const float* row = out.data.data() + b * embedding_size;
    for (size_t i = 0; i < embedding_size; ++i) {
      if (!std::isfinite(row[i])) {
        throw Error(session.name() + ": the embedding of prompt '" + std::string(prompts[b]) +
                    "' is not finite (value " + std::to_string(i) + ")");
      }
    }
    result[b].assign(row, row + embedding_size);
  }
  return result;
}

// ---------------------------------------------------------------------------

TextEncoder::TextEncoder(WordPieceTokenizer tokenizer, OnnxSession session, TextEncoderOptions options)
    : impl_(std::make_unique<Impl>(std::move(tokenizer), std::move(session), std::move(options))) {
  impl_->check_graph();
}

TextEncoder::~TextEncoder() = default;
TextEncoder::TextEncoder(TextEncoder&&) noexcept = default;
TextEncoder& TextEncoder::operator=(TextEncoder&&) noexcept = default;

size_t TextEncoder::embedding_size() const { return impl_->embedding_size; }
const WordPieceTokenizer& TextEncoder::tokenizer() const { return impl_->tokenizer; }
const OnnxSession& TextEncoder::session() const { return impl_->session; }
const TextEncoderOptions& TextEncoder::options() const { return impl_->options; }

std::string TextEncoder::normalize_prompt(std::string_view prompt) const {
  if (const auto bad = unicode::find_invalid_utf8(prompt)) {
    throw Error("prompt is not valid UTF-8 (byte " + std::to_string(*bad) + ")");
  }
  const size_t chars = unicode::count_code_points(prompt);
  if (chars > impl_->options.max_prompt_chars) {
    throw Error("prompt is " + std::to_string(chars) + " characters long; the limit is " +
                std::to_string(impl_->options.max_prompt_chars) + " (TextEncoderOptions.max_prompt_chars)");
  }
  std::string key = impl_->tokenizer.normalize(prompt);
  if (key.empty()) throw Error("prompt is empty (nothing but whitespace or control characters)");
  return key;
}

std::vector<float> TextEncoder::encode(std::string_view prompt) const {
  const std::string key = normalize_prompt(prompt);
  std::vector<float> embedding;
  if (impl_->lookup(key, embedding)) return embedding;
  embedding = std::move(impl_->run({prompt}).front());
  impl_->insert(key, embedding);
  return embedding;
}

std::vector<std::vector<float>> TextEncoder::encode_batch(const std::vector<std::string>& prompts) const {
  std::vector<std::string> keys;
  keys.reserve(prompts.size());
  for (const std::string& prompt : prompts) keys.push_back(normalize_prompt(prompt));

  std::vector<std::vector<float>> out(prompts.size());
  std::vector<std::string_view> missing;          // one prompt per distinct missing key
  std::vector<const std::string*> missing_keys;   // their keys, in the same order
  std::unordered_map<std::string, size_t> slot;   // key -> index into `missing`
  std::vector<size_t> pending(prompts.size(), 0);  // index into `missing` + 1, 0 when served
  for (size_t i = 0; i < prompts.size(); ++i) {
    const auto known = slot.find(keys[i]);
    if (known != slot.end()) {
      // Same key earlier in this batch: counted as a hit, served by its run.
      std::lock_guard<std::mutex> lock(impl_->mutex);
      ++impl_->hits;
      pending[i] = known->second + 1;
      continue;
    }
    if (impl_->lookup(keys[i], out[i])) continue;
    slot.emplace(keys[i], missing.size());
    missing.push_back(prompts[i]);
    missing_keys.push_back(&keys[i]);
    pending[i] = missing.size();
  }
  if (missing.empty()) return out;
  const std::vector<std::vector<float>> computed = impl_->run(missing);
  for (size_t i = 0; i < prompts.size(); ++i) {
    if (pending[i] == 0) continue;
    out[i] = computed[pending[i] - 1];
  }
  for (size_t m = 0; m < missing.size(); ++m) impl_->insert(*missing_keys[m], computed[m]);
  return out;
}

TextCacheStats TextEncoder::cache_stats() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return TextCacheStats{impl_->hits, impl_->misses, impl_->entries.size(), impl_->options.cache_capacity};
}

void TextEncoder::clear_cache() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->entries.clear();
  impl_->index.clear();
  impl_->hits = 0;
  impl_->misses = 0;
}

}  // namespace ardy
