// TextEncoder: tokenizer + encoder graph + LRU cache, against a tiny fake
// encoder graph (tests/data/text/fake_text_encoder.onnx) whose embeddings
// were computed in numpy (export_tools/ardy_export/cpp_fixtures.py).

#include <catch_amalgamated.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "onnx_session.hpp"
#include "support/error_message.hpp"
#include "support/test_data.hpp"
#include "text_encoder.hpp"
#include "wordpiece.hpp"

using ardy::OnnxEnvironment;
using ardy::OnnxSession;
using ardy::TextCacheStats;
using ardy::TextEncoder;
using ardy::TextEncoderOptions;
using ardy::WordPieceTokenizer;
using ardy_test::error_message;
using Catch::Matchers::ContainsSubstring;

namespace {

constexpr float kTolerance = 1e-5f;

std::shared_ptr<OnnxEnvironment> shared_env() {
  static std::shared_ptr<OnnxEnvironment> env = OnnxEnvironment::create();
  return env;
}

struct GoldenPrompt {
  std::string prompt;
  std::vector<int64_t> input_ids;
  std::vector<float> embedding;
};

struct Golden {
  size_t max_tokens = 0;
  size_t embedding_size = 0;
  std::vector<GoldenPrompt> prompts;
};

const Golden& golden() {
  static const Golden g = [] {
    const std::vector<unsigned char> bytes =
        ardy_test::read_bytes(ardy_test::data_path("text/fake_text_encoder_golden.json"));
    const nlohmann::json doc = nlohmann::json::parse(bytes.begin(), bytes.end());
    Golden out;
    out.max_tokens = doc.at("max_tokens").get<size_t>();
    out.embedding_size = doc.at("embedding_size").get<size_t>();
    for (const nlohmann::json& entry : doc.at("prompts")) {
      out.prompts.push_back({entry.at("prompt").get<std::string>(), entry.at("input_ids").get<std::vector<int64_t>>(),
                             entry.at("embedding").get<std::vector<float>>()});
    }
    return out;
  }();
  return g;
}

OnnxSession fake_session() {
  ardy::SessionOptions options;
  options.intra_op_threads = 1;
  return OnnxSession::from_file(shared_env(), ardy_test::data_path("text/fake_text_encoder.onnx"), options);
}

WordPieceTokenizer vocab() {
  ardy::WordPieceOptions options;
  options.max_tokens = golden().max_tokens;
  return WordPieceTokenizer::from_file(ardy_test::data_path("text/vocab.txt"), options);
}

TextEncoder make_encoder(TextEncoderOptions options = {}) {
  return TextEncoder(vocab(), fake_session(), std::move(options));
}

float max_abs_diff(const std::vector<float>& a, const std::vector<float>& b) {
  REQUIRE(a.size() == b.size());
  float worst = 0.0f;
  for (size_t i = 0; i < a.size(); ++i) worst = std::max(worst, std::fabs(a[i] - b[i]));
  return worst;
}

bool same_stats(const TextCacheStats& s, uint64_t hits, uint64_t misses, size_t size) {
  return s.hits == hits && s.misses == misses && s.size == size;
}

}  // namespace

TEST_CASE("embeddings match the numpy reference, ids match the HuggingFace tokenizer", "[text_encoder]") {
  const TextEncoder encoder = make_encoder();
  CHECK(encoder.embedding_size() == golden().embedding_size);
  REQUIRE(golden().prompts.size() >= 3);
  for (const GoldenPrompt& g : golden().prompts) {
    CAPTURE(g.prompt);
    CHECK(encoder.tokenizer().encode(g.prompt).input_ids == g.input_ids);
    const std::vector<float> embedding = encoder.encode(g.prompt);
    CHECK(max_abs_diff(embedding, g.embedding) <= kTolerance);
  }
}

TEST_CASE("the cache is keyed by the normalized prompt and counts hits and misses", "[text_encoder]") {
  TextEncoderOptions options;
  options.cache_capacity = 2;
  const TextEncoder encoder = make_encoder(options);
  CHECK(encoder.cache_stats().capacity == 2);
  CHECK(same_stats(encoder.cache_stats(), 0, 0, 0));

  const std::vector<float> first = encoder.encode("walk forward");
  CHECK(same_stats(encoder.cache_stats(), 0, 1, 1));
  CHECK(encoder.encode("walk forward") == first);
  CHECK(same_stats(encoder.cache_stats(), 1, 1, 1));
  // Same normalized form: case, spacing and accents do not matter.
  CHECK(encoder.normalize_prompt("  Walk \t FORWARD ") == "walk forward");
  CHECK(encoder.encode("  Walk \t FORWARD ") == first);
  CHECK(same_stats(encoder.cache_stats(), 2, 1, 1));
  // Punctuation does.
  CHECK(encoder.encode("walk, forward") != first);
  CHECK(same_stats(encoder.cache_stats(), 2, 2, 2));

  SECTION("least recently used goes first") {
    encoder.encode("walk forward");                            // hit: now most recent
    encoder.encode("run");                                     // miss: evicts "walk, forward"
    CHECK(same_stats(encoder.cache_stats(), 3, 3, 2));
    encoder.encode("walk forward");                            // still cached
    CHECK(encoder.cache_stats().hits == 4);
    encoder.encode("walk, forward");                           // was evicted
    CHECK(encoder.cache_stats().misses == 4);
  }

  SECTION("clear_cache empties it and zeroes the counts") {
    encoder.clear_cache();
    CHECK(same_stats(encoder.cache_stats(), 0, 0, 0));
    CHECK(encoder.encode("walk forward") == first);  // recomputed, same numbers
    CHECK(same_stats(encoder.cache_stats(), 0, 1, 1));
  }
}

TEST_CASE("capacity 0 turns the cache off", "[text_encoder]") {
  TextEncoderOptions options;
  options.cache_capacity = 0;
  const TextEncoder encoder = make_encoder(options);
  const std::vector<float> a = encoder.encode("jump");
  CHECK(encoder.encode("jump") == a);
  CHECK(same_stats(encoder.cache_stats(), 0, 2, 0));
}

TEST_CASE("encode_batch pads, deduplicates and agrees with encode", "[text_encoder]") {
  const TextEncoder encoder = make_encoder();
  std::vector<std::string> prompts;
  for (const GoldenPrompt& g : golden().prompts) prompts.push_back(g.prompt);
  prompts.push_back(golden().prompts[0].prompt);  // a duplicate within the batch
  const std::vector<std::vector<float>> batch = encoder.encode_batch(prompts);
  REQUIRE(batch.size() == prompts.size());
  for (size_t i = 0; i < golden().prompts.size(); ++i) {
    CAPTURE(golden().prompts[i].prompt);
    CHECK(max_abs_diff(batch[i], golden().prompts[i].embedding) <= kTolerance);
  }
  CHECK(batch.back() == batch.front());
  // "walk forward" and "Walk   FORWARD" share a key: one graph row, one miss.
  const TextCacheStats stats = encoder.cache_stats();
  CHECK(stats.misses == stats.size);
  CHECK(stats.hits + stats.misses == prompts.size());
  // Everything is cached now.
  const std::vector<std::vector<float>> again = encoder.encode_batch(prompts);
  CHECK(again == batch);
  CHECK(encoder.cache_stats().misses == stats.misses);
  CHECK(encoder.encode_batch({}).empty());
}

TEST_CASE("bad prompts give clear errors and leave the encoder usable", "[text_encoder]") {
  const TextEncoder encoder = make_encoder();
  for (const std::string& empty : {std::string(), std::string("   "), std::string("\t\n\r "),
                                   std::string("\x07\x1b"), std::string("\xE2\x80\x8B")}) {
    CAPTURE(empty);
    CHECK_THAT(error_message([&] { encoder.encode(empty); }), ContainsSubstring("prompt is empty"));
  }
  const std::string long_prompt(10000, 'a');
  CHECK_THAT(error_message([&] { encoder.encode(long_prompt); }),
             ContainsSubstring("prompt is 10000 characters long; the limit is 2000"));
  const std::string at_limit = std::string(1999, ' ') + "w";  // 2000 code points
  CHECK(encoder.encode(at_limit).size() == encoder.embedding_size());
  std::string multibyte;
  for (int i = 0; i < 2001; ++i) multibyte += "\xC3\xA9";  // é: counted as characters, not bytes
  CHECK_THAT(error_message([&] { encoder.encode(multibyte); }),
             ContainsSubstring("prompt is 2001 characters long"));
  CHECK_THAT(error_message([&] { encoder.encode("walk \xC3("); }),
             ContainsSubstring("prompt is not valid UTF-8 (byte 5)"));
  CHECK_THAT(error_message([&] { encoder.encode_batch({"walk", ""}); }), ContainsSubstring("prompt is empty"));

  TextEncoderOptions small;
  small.max_prompt_chars = 5;
  CHECK_THAT(error_message([&] { make_encoder(small).encode("walk forward"); }),
             ContainsSubstring("prompt is 12 characters long; the limit is 5"));

  CHECK(max_abs_diff(encoder.encode(golden().prompts[0].prompt), golden().prompts[0].embedding) <= kTolerance);
}

TEST_CASE("graphs without the text encoder's signature are refused", "[text_encoder]") {
  ardy::SessionOptions one;
  one.intra_op_threads = 1;
  const auto session = [&](const char* file) {
    return OnnxSession::from_file(shared_env(), ardy_test::data_path(file), one);
  };
  CHECK_THAT(error_message([&] { TextEncoder(vocab(), session("foundation/mlp.onnx")); }),
             ContainsSubstring("mlp.onnx: the text encoder graph has no input 'input_ids'"));
  TextEncoderOptions renamed;
  renamed.input_ids_name = "ids";
  renamed.attention_mask_name = "mask";
  CHECK_THAT(error_message([&] { TextEncoder(vocab(), session("foundation/tokens.onnx"), renamed); }),
             ContainsSubstring("tokens.onnx: the text encoder graph has no output 'embedding'"));
  renamed.embedding_name = "mask_sum";
  CHECK_THAT(error_message([&] { TextEncoder(vocab(), session("foundation/tokens.onnx"), renamed); }),
             ContainsSubstring("output 'mask_sum' must be float32 [batch, D]"));
  TextEncoderOptions wrong_output;
  wrong_output.embedding_name = "pooled";
  CHECK_THAT(error_message([&] { TextEncoder(vocab(), session("text/fake_text_encoder.onnx"), wrong_output); }),
             ContainsSubstring("no output 'pooled'"));
}

TEST_CASE("a moved encoder keeps working; several threads share one", "[text_encoder]") {
  TextEncoder moved = make_encoder();
  TextEncoder encoder = std::move(moved);
  const std::vector<GoldenPrompt>& prompts = golden().prompts;
  CHECK(max_abs_diff(encoder.encode(prompts[1].prompt), prompts[1].embedding) <= kTolerance);

  TextEncoderOptions options;
  options.cache_capacity = 2;  // smaller than the prompt set: eviction under contention
  const TextEncoder shared = make_encoder(options);
  std::vector<float> worst(4, 0.0f);
  std::vector<std::thread> threads;
  for (size_t t = 0; t < 4; ++t) {
    threads.emplace_back([&, t] {
      for (int repeat = 0; repeat < 10; ++repeat) {
        for (size_t i = 0; i < prompts.size(); ++i) {
          const GoldenPrompt& g = prompts[(i + t) % prompts.size()];
          const std::vector<float> e = shared.encode(g.prompt);
          for (size_t k = 0; k < e.size(); ++k) worst[t] = std::max(worst[t], std::fabs(e[k] - g.embedding[k]));
        }
      }
    });
  }
  for (std::thread& thread : threads) thread.join();
  for (const float w : worst) CHECK(w <= kTolerance);
  const TextCacheStats stats = shared.cache_stats();
  CHECK(stats.hits + stats.misses == 4u * 10u * prompts.size());
  CHECK(stats.size <= 2);
}

// The shipped default package's text encoder (all-MiniLM-L6-v2, stored with
// int8 weights by `ardy-export export`) against sentence-transformers' own
// float32 embeddings (tests/data/text/wordpiece_cases.json, "embeddings"):
// token ids exactly, embeddings by cosine within the exporter's acceptance
// bound for int8 weights (INT8_MIN_COSINE = 0.995 in
// export_tools/ardy_export/text/export.py; 1e-4 per component if the package
// says float32 weights), alone and batched with padding.
TEST_CASE("the shipped text encoder matches sentence-transformers' embeddings", "[text_encoder][shipped]") {
  const std::string package = ARDY_SHIPPED_MODEL_DIR;
  const std::vector<unsigned char> model_bytes = ardy_test::read_bytes(package + "/model.json");
  const nlohmann::json text_settings = nlohmann::json::parse(model_bytes.begin(), model_bytes.end()).at("text");
  const std::string weights = text_settings.at("weights").get<std::string>();
  REQUIRE((weights == "int8" || weights == "float32"));
  const bool int8 = weights == "int8";
  const std::vector<unsigned char> bytes = ardy_test::read_bytes(ardy_test::data_path("text/wordpiece_cases.json"));
  const nlohmann::json doc = nlohmann::json::parse(bytes.begin(), bytes.end());
  ardy::WordPieceOptions options;
  options.max_tokens = text_settings.at("max_tokens").get<size_t>();
  REQUIRE(options.max_tokens == doc.at("settings").at("max_tokens").get<size_t>());
  const TextEncoder encoder(WordPieceTokenizer::from_file(package + "/vocab.txt", options),
                            OnnxSession::from_file(shared_env(), package + "/" + text_settings.at("graph").get<std::string>()));
  REQUIRE(encoder.embedding_size() == doc.at("settings").at("embedding_size").get<size_t>());

  const auto matches = [&](const std::vector<float>& found, const std::vector<float>& want) {
    REQUIRE(found.size() == want.size());
    double dot = 0.0, norm_found = 0.0, norm_want = 0.0;
    for (size_t i = 0; i < want.size(); ++i) {
      dot += double(found[i]) * want[i];
      norm_found += double(found[i]) * found[i];
      norm_want += double(want[i]) * want[i];
    }
    const double cosine = dot / std::sqrt(norm_found * norm_want);
    CAPTURE(cosine, max_abs_diff(found, want));
    CHECK(std::fabs(std::sqrt(norm_found) - 1.0) < 1e-4);  // normalized, like the reference
    if (int8) {
      CHECK(cosine >= 0.995);
    } else {
      CHECK(max_abs_diff(found, want) <= 1e-4f);
    }
  };
  size_t checked = 0;
  std::vector<std::string> prompts;
  std::vector<std::vector<float>> expected;
  for (const nlohmann::json& entry : doc.at("embeddings")) {
    const std::string text = entry.at("text").get<std::string>();
    if (encoder.tokenizer().normalize(text).empty()) continue;  // an empty prompt is refused by design
    CAPTURE(text);
    CHECK(encoder.tokenizer().encode(text).input_ids == entry.at("input_ids").get<std::vector<int64_t>>());
    prompts.push_back(text);
    expected.push_back(entry.at("embedding").get<std::vector<float>>());
    matches(encoder.encode(text), expected.back());
    ++checked;
  }
  CHECK(checked >= 3);
  // Batched with padding: the masked mean pooling makes padding invisible.
  encoder.clear_cache();
  const std::vector<std::vector<float>> batch = encoder.encode_batch(prompts);
  REQUIRE(batch.size() == prompts.size());
  for (size_t i = 0; i < prompts.size(); ++i) {
    CAPTURE(prompts[i]);
    matches(batch[i], expected[i]);
    CHECK(max_abs_diff(batch[i], encoder.encode(prompts[i])) <= 1e-5f);
  }
  // Different prompts are told apart: the embeddings are not all the same vector.
  REQUIRE(expected.size() >= 2);
  CHECK(max_abs_diff(encoder.encode(prompts[0]), encoder.encode(prompts[1])) > 1e-2f);
}
