// WordPieceTokenizer: exact id parity with the HuggingFace tokenizer of
// all-MiniLM-L6-v2 on the committed case lists, the rules one by one on a
// tiny vocabulary, vocabulary validation, and concurrent use.

#include <catch_amalgamated.hpp>

#include <cstdint>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "support/error_message.hpp"
#include "support/test_data.hpp"
#include "wordpiece.hpp"

using ardy::WordPieceEncoding;
using ardy::WordPieceOptions;
using ardy::WordPieceTokenizer;
using ardy_test::error_message;
using Catch::Matchers::ContainsSubstring;
using Strings = std::vector<std::string>;

namespace {

std::string vocab_path() { return ardy_test::data_path("text/vocab.txt"); }

const WordPieceTokenizer& minilm() {
  static const WordPieceTokenizer tokenizer = WordPieceTokenizer::from_file(vocab_path());
  return tokenizer;
}

nlohmann::json read_json(const std::string& relative) {
  const std::vector<unsigned char> bytes = ardy_test::read_bytes(ardy_test::data_path(relative));
  return nlohmann::json::parse(bytes.begin(), bytes.end());
}

// Every case of a file: {"text", "input_ids", "attention_mask"}, exact equality.
size_t check_cases(const nlohmann::json& cases, size_t max_tokens) {
  size_t checked = 0;
  for (const nlohmann::json& entry : cases) {
    const std::string text = entry.at("text").get<std::string>();
    const auto ids = entry.at("input_ids").get<std::vector<int64_t>>();
    const auto mask = entry.at("attention_mask").get<std::vector<int64_t>>();
    CAPTURE(text);
    const WordPieceEncoding encoding = minilm().encode(text, max_tokens);
    CHECK(encoding.input_ids == ids);
    CHECK(encoding.attention_mask == mask);
    ++checked;
  }
  return checked;
}

// A vocabulary small enough to reason about by hand.
const char* kTinyVocab =
    "[PAD]\n[UNK]\n[CLS]\n[SEP]\n[MASK]\n"          // 0-4
    "un\n##aff\n##able\nwant\n##ed\n"               // 5-9
    "walk\n##ing\n,\n!\n.\nrun\n"                   // 10-15
    "cafe\nhello\nworld\n\xE4\xBA\xBA\n##s\n"       // 16-20: 人
    "a\n##b\n##c\nabc\n";                           // 21-24

WordPieceTokenizer tiny(WordPieceOptions options = {}) {
  return WordPieceTokenizer::from_string(kTinyVocab, "tiny-vocab", std::move(options));
}

std::vector<int64_t> ids_of(const WordPieceTokenizer& t, const std::string& text) {
  return t.encode(text).input_ids;
}

}  // namespace

TEST_CASE("ids equal the HuggingFace tokenizer on every committed case", "[wordpiece]") {
  REQUIRE(minilm().vocab_size() == 30522);
  CHECK(minilm().unk_id() == 100);
  CHECK(minilm().cls_id() == 101);
  CHECK(minilm().sep_id() == 102);
  CHECK(minilm().pad_id() == 0);

  SECTION("export_tools' list (tests/data/text/wordpiece_cases.json)") {
    const nlohmann::json doc = read_json("text/wordpiece_cases.json");
    const nlohmann::json& settings = doc.at("settings");
    CHECK(settings.at("vocab_size").get<size_t>() == minilm().vocab_size());
    CHECK(settings.at("special_tokens").at("unk").at("id").get<int64_t>() == minilm().unk_id());
    CHECK(settings.at("special_tokens").at("mask").at("id").get<int64_t>() == *minilm().find_token("[MASK]"));
    const size_t checked = check_cases(doc.at("cases"), settings.at("max_tokens").get<size_t>());
    CHECK(checked >= 60);
  }

  SECTION("the runtime's own edge cases (tests/data/text/wordpiece_cases_cpp.json)") {
    const nlohmann::json doc = read_json("text/wordpiece_cases_cpp.json");
    const size_t checked = check_cases(doc.at("cases"), doc.at("max_tokens").get<size_t>());
    CHECK(checked >= 60);
  }
}

TEST_CASE("a vocabulary from bytes equals the same vocabulary from its file", "[wordpiece]") {
  const std::vector<unsigned char> bytes = ardy_test::read_bytes(vocab_path());
  const WordPieceTokenizer from_bytes = WordPieceTokenizer::from_memory(bytes.data(), bytes.size(), "packed/vocab.txt");
  CHECK(from_bytes.name() == "packed/vocab.txt");
  CHECK(from_bytes.vocab_size() == minilm().vocab_size());
  for (const char* text : {"A person walks forward, then waves!", "caf\xC3\xA9 na\xC3\xAFve", "unaffable"}) {
    CHECK(from_bytes.encode(text).input_ids == minilm().encode(text).input_ids);
  }
  CHECK(minilm().token(101) == "[CLS]");
  CHECK(minilm().find_token("walk") == std::optional<int64_t>(3328));
  CHECK_FALSE(minilm().find_token("no-such-token").has_value());
}

TEST_CASE("WordPiece: greedy longest match first, ## continuations, [UNK] words", "[wordpiece]") {
  const WordPieceTokenizer t = tiny();
  CHECK(t.tokenize("unaffable") == Strings{"un", "##aff", "##able"});
  CHECK(t.tokenize("wanted walking") == Strings{"want", "##ed", "walk", "##ing"});
  CHECK(t.tokenize("abc") == Strings{"abc"});        // the longest match wins over a + ##b + ##c
  CHECK(t.tokenize("abcbc") == Strings{"abc", "##b", "##c"});
  CHECK(t.tokenize("ab") == Strings{"a", "##b"});
  CHECK(t.tokenize("walkx") == Strings{"[UNK]"});    // no match for the rest: the whole word
  CHECK(t.tokenize("walk walkx run") == Strings{"walk", "[UNK]", "run"});
  CHECK(t.tokenize("xyz") == Strings{"[UNK]"});
  CHECK(ids_of(t, "unaffable!") == std::vector<int64_t>{2, 5, 6, 7, 13, 3});
}

TEST_CASE("normalization: cleaning, CJK, accents, case, punctuation", "[wordpiece]") {
  const WordPieceTokenizer t = tiny();
  CHECK(t.basic_tokenize("Hello,World!") == Strings{"hello", ",", "world", "!"});
  CHECK(t.basic_tokenize("  hello \t\n world  ") == Strings{"hello", "world"});
  CHECK(t.basic_tokenize("CAF\xC3\x89") == Strings{"cafe"});             // É: NFD, mark dropped, lower
  CHECK(t.basic_tokenize("cafe\xCC\x81") == Strings{"cafe"});            // decomposed input
  CHECK(t.basic_tokenize("a\xE4\xBA\xBA" "b") == Strings{"a", "\xE4\xBA\xBA", "b"});  // 人 stands alone
  CHECK(t.basic_tokenize(std::string("he\0llo\x07 wor\xE2\x80\x8B" "ld", 16)) == Strings{"hello", "world"});
  CHECK(t.basic_tokenize("a\xC2\xA0" "b\xE3\x80\x80" "c") == Strings{"a", "b", "c"});  // NBSP, ideographic space
  CHECK(t.basic_tokenize("x+y=z^2") == Strings{"x", "+", "y", "=", "z", "^", "2"});
  CHECK(t.basic_tokenize("\xE2\x80\x94" "dash") == Strings{"\xE2\x80\x94", "dash"});    // em dash is punctuation
  CHECK(t.basic_tokenize("\xE2\x82\xAC" "5") == Strings{"\xE2\x82\xAC" "5"});  // €: a symbol, not punctuation
  CHECK(t.normalize("  Walk,   RUN! ") == "walk , run !");
  CHECK(t.normalize("\t\n ").empty());

  SECTION("options: no lower-casing keeps accents unless asked") {
    WordPieceOptions cased;
    cased.lower_case = false;
    const WordPieceTokenizer c = tiny(cased);
    CHECK_FALSE(*c.options().strip_accents);
    CHECK(c.basic_tokenize("Caf\xC3\xA9") == Strings{"Caf\xC3\xA9"});
    cased.strip_accents = true;
    CHECK(tiny(cased).basic_tokenize("Caf\xC3\xA9") == Strings{"Cafe"});
    WordPieceOptions no_cjk;
    no_cjk.split_cjk_ideographs = false;
    CHECK(tiny(no_cjk).basic_tokenize("a\xE4\xBA\xBA" "b") == Strings{"a\xE4\xBA\xBA" "b"});
  }
}

TEST_CASE("special tokens written in the text keep their ids", "[wordpiece]") {
  const WordPieceTokenizer t = tiny();
  CHECK(ids_of(t, "walk [SEP] run") == std::vector<int64_t>{2, 10, 3, 15, 3});
  CHECK(ids_of(t, "walk[MASK]ing") == std::vector<int64_t>{2, 10, 4, 1, 3});  // "ing" starts a new word
  CHECK(t.tokenize("[sep]") == Strings{"[UNK]", "[UNK]", "[UNK]"});         // case-sensitive: "[", "sep", "]"
  CHECK(t.basic_tokenize("a[CLS][CLS]b") == Strings{"a", "[CLS]", "[CLS]", "b"});
  CHECK(t.normalize("walk[SEP]run") == t.normalize("walk [SEP] run"));
  WordPieceOptions none;
  none.special_tokens.clear();
  CHECK(tiny(none).tokenize("[SEP]") == Strings{"[UNK]", "[UNK]", "[UNK]"});
}

TEST_CASE("long words become [UNK]; truncation keeps [CLS] ... [SEP]", "[wordpiece]") {
  WordPieceOptions options;
  options.max_chars_per_word = 5;
  const WordPieceTokenizer t = tiny(options);
  CHECK(t.tokenize("abcbc") == Strings{"abc", "##b", "##c"});  // 5 characters: allowed
  CHECK(t.tokenize("abcbcb") == Strings{"[UNK]"});              // 6: too long

  const WordPieceTokenizer u = tiny();
  const WordPieceEncoding full = u.encode("walk walk walk walk", 6);
  CHECK(full.input_ids == std::vector<int64_t>{2, 10, 10, 10, 10, 3});
  CHECK_FALSE(full.truncated);
  const WordPieceEncoding cut = u.encode("walk walk walk walk walk", 6);
  CHECK(cut.input_ids == std::vector<int64_t>{2, 10, 10, 10, 10, 3});
  CHECK(cut.attention_mask == std::vector<int64_t>(6, 1));
  CHECK(cut.truncated);
  CHECK(u.encode("unaffable", 3).input_ids == std::vector<int64_t>{2, 5, 3});  // cut inside a word
  CHECK(u.encode("walk", 2).input_ids == std::vector<int64_t>{2, 3});
  CHECK(u.encode("").input_ids == std::vector<int64_t>{2, 3});
  CHECK_THAT(error_message([&] { u.encode("walk", 1); }),
             ContainsSubstring("max_tokens must be at least 2") && ContainsSubstring("got 1"));
}

TEST_CASE("invalid UTF-8 text is refused with its byte offset", "[wordpiece]") {
  const WordPieceTokenizer t = tiny();
  CHECK_THAT(error_message([&] { t.encode("walk \xC3("); }),
             ContainsSubstring("tiny-vocab: text: invalid UTF-8 at byte 5"));
  CHECK_THAT(error_message([&] { t.basic_tokenize("\xFF"); }), ContainsSubstring("invalid UTF-8 at byte 0"));
  CHECK(t.tokenize("walk") == Strings{"walk"});  // still usable
}

TEST_CASE("bad vocabularies are refused with a message naming the problem", "[wordpiece]") {
  const auto load = [](const std::string& text, WordPieceOptions options = {}) {
    return error_message([&] { WordPieceTokenizer::from_string(text, "v.txt", std::move(options)); });
  };
  const std::string specials = "[PAD]\n[UNK]\n[CLS]\n[SEP]\n[MASK]\n";
  CHECK_THAT(load(""), ContainsSubstring("v.txt: empty vocabulary"));
  CHECK_THAT(load(specials + "a\n\nb\n"), ContainsSubstring("v.txt: line 7 is empty"));
  CHECK_THAT(load(specials + "walk\nrun\nwalk\n"),
             ContainsSubstring("v.txt: token 'walk' appears twice (lines 6 and 8)"));
  CHECK_THAT(load("[PAD]\n[CLS]\n[SEP]\n[MASK]\n"), ContainsSubstring("v.txt: the vocabulary has no '[UNK]' token"));
  CHECK_THAT(load("[PAD]\n[UNK]\n[CLS]\n[SEP]\n"),
             ContainsSubstring("no '[MASK]' token (WordPieceOptions.special_tokens)"));
  CHECK_THAT(load(specials + "ok\nbad\xC3(\n"), ContainsSubstring("v.txt: line 7 is not valid UTF-8"));
  WordPieceOptions bad_max;
  bad_max.max_tokens = 1;
  CHECK_THAT(load(specials, bad_max), ContainsSubstring("max_tokens must be at least 2"));
  CHECK_THAT(error_message([] { WordPieceTokenizer::from_file(ardy_test::data_path("text/missing_vocab.txt")); }),
             ContainsSubstring("missing_vocab.txt: file not found"));
  CHECK_THAT(error_message([] { WordPieceTokenizer::from_file(ardy_test::data_path("text")); }),
             ContainsSubstring("not a regular file"));
  CHECK_THAT(error_message([] { WordPieceTokenizer::from_memory(nullptr, 4, "null"); }),
             ContainsSubstring("null: null vocabulary buffer"));
  CHECK_THAT(error_message([&] { minilm().token(30522); }), ContainsSubstring("token id 30522 out of range"));

  SECTION("CRLF line ends and a missing final newline are accepted") {
    const WordPieceTokenizer t = WordPieceTokenizer::from_string(
        "[PAD]\r\n[UNK]\r\n[CLS]\r\n[SEP]\r\n[MASK]\r\nwalk", "crlf.txt");
    CHECK(t.vocab_size() == 6);
    CHECK(t.find_token("walk") == std::optional<int64_t>(5));
    CHECK(t.find_token("[MASK]") == std::optional<int64_t>(4));
  }
}

TEST_CASE("one tokenizer serves several threads at once", "[wordpiece]") {
  const std::vector<std::string> texts{"A person walks forward slowly.", "caf\xC3\xA9 na\xC3\xAFve WAVE-Right-Hand!!",
                                       "\xE6\xAD\xA9\xE3\x81\x8F walk", "unaffable [SEP] x"};
  std::vector<std::vector<int64_t>> expected;
  for (const std::string& text : texts) expected.push_back(minilm().encode(text).input_ids);
  const WordPieceTokenizer copy = minilm();  // copies share the vocabulary
  std::vector<int> mismatches(4, 0);
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&, t] {
      const WordPieceTokenizer& tokenizer = t % 2 ? copy : minilm();
      for (int repeat = 0; repeat < 50; ++repeat) {
        for (size_t i = 0; i < texts.size(); ++i) {
          if (tokenizer.encode(texts[i]).input_ids != expected[i]) ++mismatches[static_cast<size_t>(t)];
        }
      }
    });
  }
  for (std::thread& thread : threads) thread.join();
  CHECK(mismatches == std::vector<int>(4, 0));
}
