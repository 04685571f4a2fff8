// OnnxSession: loading (file, memory, broken inputs), signatures, numerics
// against numpy golden vectors, and the validation run() does before ORT.

#include <catch_amalgamated.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "onnx_session.hpp"
#include "support/error_message.hpp"
#include "support/test_data.hpp"

using ardy::Error;
using ardy_test::error_message;
using ardy::OnnxEnvironment;
using ardy::OnnxSession;
using ardy::Tensor;
using ardy::TensorInfo;
using Catch::Matchers::ContainsSubstring;

namespace {

constexpr float kTolerance = 1e-5f;

std::string mlp_path() { return ardy_test::data_path("foundation/mlp.onnx"); }
std::string tokens_path() { return ardy_test::data_path("foundation/tokens.onnx"); }

std::shared_ptr<OnnxEnvironment> shared_env() {
  // One environment for the whole suite, as the runtime uses it.
  static std::shared_ptr<OnnxEnvironment> env = OnnxEnvironment::create();
  return env;
}

ardy::SessionOptions one_thread() {
  ardy::SessionOptions options;
  options.intra_op_threads = 1;
  return options;
}

struct Golden {
  Tensor x;
  Tensor y;
  Tensor norm;
};

Tensor golden_tensor(const ardy_test::JsonValue& entry) {
  return Tensor::float32(entry.at("shape").ints(), entry.at("data").floats());
}

Golden load_golden() {
  const ardy_test::JsonValue json = ardy_test::read_json(ardy_test::data_path("foundation/mlp_golden.json"));
  return Golden{golden_tensor(json.at("inputs").at("x")), golden_tensor(json.at("outputs").at("y")),
                golden_tensor(json.at("outputs").at("norm"))};
}

float max_abs_diff(const std::vector<float>& a, const std::vector<float>& b) {
  REQUIRE(a.size() == b.size());
  float worst = 0.0f;
  for (size_t i = 0; i < a.size(); ++i) worst = std::max(worst, std::fabs(a[i] - b[i]));
  return worst;
}


// The first `rows` rows of a [batch, ...] tensor.
Tensor first_rows(const Tensor& t, int64_t rows) {
  Tensor out = t;
  const size_t row_size = t.data.size() / static_cast<size_t>(t.shape[0]);
  out.shape[0] = rows;
  out.data.resize(row_size * static_cast<size_t>(rows));
  return out;
}

}  // namespace

TEST_CASE("the environment reports the loaded runtime version", "[onnx_session]") {
  CHECK_THAT(OnnxEnvironment::runtime_version(), ContainsSubstring("1."));
  CHECK(shared_env() != nullptr);
}

TEST_CASE("the environment turns ONNX Runtime's telemetry off before it starts", "[onnx_session]") {
  // Without it ONNX Runtime's Linux build posts events to Microsoft some
  // seconds after the first environment. The tests do not set the variable
  // themselves, so "1" here is the runtime's doing.
  const auto environment = OnnxEnvironment::create();
  const char* value = std::getenv(ardy::kOrtTelemetryVariable);
  REQUIRE(value != nullptr);
  CHECK(std::string(value) == "1");
}

TEST_CASE("intra-op thread count resolves to all cores but one, at least one", "[onnx_session]") {
  CHECK(ardy::effective_intra_op_threads(3) == 3);
  const int automatic = ardy::effective_intra_op_threads(0);
  CHECK(automatic >= 1);
  const int hardware = static_cast<int>(std::thread::hardware_concurrency());
  if (hardware > 1) CHECK(automatic == hardware - 1);
}

TEST_CASE("the MLP fixture's signature: names, dtypes, symbolic batch axis", "[onnx_session]") {
  const OnnxSession session = OnnxSession::from_file(shared_env(), mlp_path(), one_thread());
  CHECK(session.name() == mlp_path());

  REQUIRE(session.inputs().size() == 1);
  const TensorInfo& x = session.inputs()[0];
  CHECK(x.name == "x");
  CHECK(x.dtype == "float32");
  CHECK(x.shape == std::vector<int64_t>{-1, 8});
  CHECK(x.symbolic_dims == std::vector<std::string>{"batch", ""});

  REQUIRE(session.outputs().size() == 2);
  const TensorInfo& y = session.outputs()[0];
  CHECK(y.name == "y");
  CHECK(y.dtype == "float32");
  CHECK(y.shape == std::vector<int64_t>{-1, 4});
  CHECK(y.symbolic_dims == std::vector<std::string>{"batch", ""});
  const TensorInfo& norm = session.outputs()[1];
  CHECK(norm.name == "norm");
  CHECK(norm.dtype == "float32");
  CHECK(norm.shape == std::vector<int64_t>{-1});
  CHECK(norm.symbolic_dims == std::vector<std::string>{"batch"});

  CHECK(session.find_input("x") == &x);
  CHECK(session.find_output("norm") == &norm);
  CHECK(session.find_input("y") == nullptr);
  CHECK(session.find_output("nope") == nullptr);
}

TEST_CASE("the MLP matches the numpy golden vectors, loaded from file and from memory", "[onnx_session]") {
  const Golden golden = load_golden();
  REQUIRE(golden.x.shape == std::vector<int64_t>{3, 8});

  auto check_session = [&](const OnnxSession& session) {
    const std::vector<Tensor> out = session.run({{"x", golden.x}}, {"y", "norm"});
    REQUIRE(out.size() == 2);
    CHECK(out[0].dtype == ardy::ElementType::float32);
    CHECK(out[0].shape == golden.y.shape);
    CHECK(out[1].shape == golden.norm.shape);
    CHECK(max_abs_diff(out[0].data, golden.y.data) <= kTolerance);
    CHECK(max_abs_diff(out[1].data, golden.norm.data) <= kTolerance);
  };

  SECTION("from file") { check_session(OnnxSession::from_file(shared_env(), mlp_path(), one_thread())); }

  SECTION("from memory, buffer released right after loading") {
    std::vector<unsigned char> bytes = ardy_test::read_bytes(mlp_path());
    const OnnxSession session = OnnxSession::from_memory(shared_env(), bytes.data(), bytes.size(), "mlp (memory)");
    bytes.assign(bytes.size(), 0);  // the session must not depend on the caller's buffer
    bytes.clear();
    bytes.shrink_to_fit();
    CHECK(session.name() == "mlp (memory)");
    CHECK(session.inputs().size() == 1);
    check_session(session);
  }

  SECTION("default options (automatic thread count)") {
    check_session(OnnxSession::from_file(shared_env(), mlp_path()));
  }
}

TEST_CASE("the batch axis is symbolic: batch 1 reproduces the first golden row", "[onnx_session]") {
  const Golden golden = load_golden();
  const OnnxSession session = OnnxSession::from_file(shared_env(), mlp_path(), one_thread());
  const std::vector<Tensor> out = session.run({{"x", first_rows(golden.x, 1)}}, {"y", "norm"});
  CHECK(out[0].shape == std::vector<int64_t>{1, 4});
  CHECK(out[1].shape == std::vector<int64_t>{1});
  CHECK(max_abs_diff(out[0].data, first_rows(golden.y, 1).data) <= kTolerance);
  CHECK(max_abs_diff(out[1].data, first_rows(golden.norm, 1).data) <= kTolerance);
}

TEST_CASE("outputs come back in the order asked; none asked means all in graph order", "[onnx_session]") {
  const Golden golden = load_golden();
  const OnnxSession session = OnnxSession::from_file(shared_env(), mlp_path(), one_thread());

  const std::vector<Tensor> reversed = session.run({{"x", golden.x}}, {"norm", "y"});
  REQUIRE(reversed.size() == 2);
  CHECK(reversed[0].shape == std::vector<int64_t>{3});
  CHECK(max_abs_diff(reversed[0].data, golden.norm.data) <= kTolerance);

  const std::vector<Tensor> only_norm = session.run({{"x", golden.x}}, {"norm"});
  REQUIRE(only_norm.size() == 1);
  CHECK(max_abs_diff(only_norm[0].data, golden.norm.data) <= kTolerance);

  const std::vector<Tensor> all = session.run({{"x", golden.x}}, {});
  REQUIRE(all.size() == 2);
  CHECK(max_abs_diff(all[0].data, golden.y.data) <= kTolerance);
  CHECK(max_abs_diff(all[1].data, golden.norm.data) <= kTolerance);
}

TEST_CASE("loading failures are ardy::Error naming the model", "[onnx_session]") {
  const auto env = shared_env();

  SECTION("missing file") {
    const std::string path = ardy_test::data_path("foundation/does_not_exist.onnx");
    const std::string message = error_message([&] { OnnxSession::from_file(env, path); });
    CHECK_THAT(message, ContainsSubstring(path) && ContainsSubstring("file not found"));
  }

  SECTION("a folder instead of a file") {
    const std::string path = ardy_test::data_path("foundation");
    CHECK_THAT(error_message([&] { OnnxSession::from_file(env, path); }),
               ContainsSubstring(path) && ContainsSubstring("not a regular file"));
  }

  SECTION("empty buffer") {
    const std::vector<unsigned char> empty;
    CHECK_THAT(error_message([&] { OnnxSession::from_memory(env, empty.data(), empty.size(), "empty.onnx"); }),
               ContainsSubstring("empty.onnx") && ContainsSubstring("empty buffer"));
    const unsigned char one_byte = 0;
    CHECK_THAT(error_message([&] { OnnxSession::from_memory(env, nullptr, 1, "null.onnx"); }),
               ContainsSubstring("null.onnx") && ContainsSubstring("empty buffer"));
    CHECK_THAT(error_message([&] { OnnxSession::from_memory(env, &one_byte, 0, "zero.onnx"); }),
               ContainsSubstring("zero.onnx: empty buffer"));
  }

  SECTION("random garbage bytes") {
    std::mt19937 rng(1234);  // mt19937's sequence is fixed by the standard: same bytes everywhere
    for (const size_t size : {1u, 7u, 64u, 4096u}) {
      std::vector<unsigned char> garbage(size);
      for (unsigned char& b : garbage) b = static_cast<unsigned char>(rng() & 0xFF);
      const std::string name = "garbage" + std::to_string(size) + ".onnx";
      CHECK_THAT(error_message([&] { OnnxSession::from_memory(env, garbage.data(), garbage.size(), name); }),
                 ContainsSubstring(name + ": not a valid ONNX model ("));
    }
  }

  SECTION("a JSON file given as a model") {
    const std::string path = ardy_test::data_path("foundation/mlp_golden.json");
    CHECK_THAT(error_message([&] { OnnxSession::from_file(env, path); }),
               ContainsSubstring(path + ": not a valid ONNX model ("));
  }

  SECTION("truncated model") {
    const std::vector<unsigned char> bytes = ardy_test::read_bytes(mlp_path());
    REQUIRE(bytes.size() > 100);
    for (const size_t keep : {size_t{1}, size_t{16}, bytes.size() / 2, bytes.size() - 1}) {
      const std::string name = "mlp-truncated-" + std::to_string(keep) + ".onnx";
      const std::string message = error_message([&] { OnnxSession::from_memory(env, bytes.data(), keep, name); });
      CHECK_THAT(message, ContainsSubstring(name + ": not a valid ONNX model ("));
    }
  }

  SECTION("no environment") {
    CHECK_THAT(error_message([&] { OnnxSession::from_file(nullptr, mlp_path()); }),
               ContainsSubstring("no ONNX Runtime environment"));
  }

  SECTION("negative thread count") {
    ardy::SessionOptions options;
    options.intra_op_threads = -2;
    CHECK_THAT(error_message([&] { OnnxSession::from_file(env, mlp_path(), options); }),
               ContainsSubstring("intra_op_threads") && ContainsSubstring("-2"));
  }
}

TEST_CASE("run() refuses bad inputs with a message naming the session and the input", "[onnx_session]") {
  const Golden golden = load_golden();
  const OnnxSession session = OnnxSession::from_file(shared_env(), mlp_path(), one_thread());
  const std::string name = session.name();

  SECTION("wrong input name") {
    CHECK_THAT(error_message([&] { session.run({{"input", golden.x}}, {"y"}); }),
               ContainsSubstring(name + ": unknown input 'input'") && ContainsSubstring("'x'"));
  }

  SECTION("missing input") {
    CHECK_THAT(error_message([&] { session.run({}, {"y"}); }),
               ContainsSubstring(name + ": missing input 'x' [batch, 8] float32"));
  }

  SECTION("input given twice") {
    CHECK_THAT(error_message([&] { session.run({{"x", golden.x}, {"x", golden.x}}, {"y"}); }),
               ContainsSubstring("input 'x' given more than once"));
  }

  SECTION("wrong fixed dimension") {
    const Tensor x = Tensor::float32({3, 7}, std::vector<float>(21, 0.5f));
    CHECK_THAT(error_message([&] { session.run({{"x", x}}, {"y"}); }),
               ContainsSubstring(name + ": input 'x': expected shape [batch, 8], got [3, 7]"));
  }

  SECTION("wrong rank") {
    const Tensor x = Tensor::float32({24}, std::vector<float>(24, 0.5f));
    CHECK_THAT(error_message([&] { session.run({{"x", x}}, {"y"}); }),
               ContainsSubstring("input 'x': expected rank 2 [batch, 8], got shape [24]"));
  }

  SECTION("element count does not match the shape") {
    const Tensor x = Tensor::float32({3, 8}, std::vector<float>(23, 0.5f));
    CHECK_THAT(error_message([&] { session.run({{"x", x}}, {"y"}); }),
               ContainsSubstring("input 'x': shape [3, 8] needs 24 elements, got 23"));
  }

  SECTION("negative or overflowing dimensions") {
    const Tensor negative = Tensor::float32({-3, 8}, std::vector<float>(24, 0.5f));
    CHECK_THAT(error_message([&] { session.run({{"x", negative}}, {"y"}); }),
               ContainsSubstring("input 'x': negative dimension"));
    const int64_t huge = std::numeric_limits<int64_t>::max() / 2;
    const Tensor overflow = Tensor::float32({huge, 8}, std::vector<float>(8, 0.5f));
    CHECK_THAT(error_message([&] { session.run({{"x", overflow}}, {"y"}); }),
               ContainsSubstring("input 'x'") && ContainsSubstring("too many elements"));
  }

  SECTION("NaN input") {
    Tensor x = golden.x;
    x.data[5] = std::numeric_limits<float>::quiet_NaN();
    CHECK_THAT(error_message([&] { session.run({{"x", x}}, {"y"}); }),
               ContainsSubstring(name + ": input 'x': element 5 is NaN"));
  }

  SECTION("infinite input") {
    Tensor x = golden.x;
    x.data[23] = -std::numeric_limits<float>::infinity();
    CHECK_THAT(error_message([&] { session.run({{"x", x}}, {"y"}); }),
               ContainsSubstring("input 'x': element 23 is infinite"));
  }

  SECTION("wrong dtype") {
    const Tensor x = Tensor::int64({3, 8}, std::vector<int64_t>(24, 1));
    CHECK_THAT(error_message([&] { session.run({{"x", x}}, {"y"}); }),
               ContainsSubstring("input 'x': expected dtype float32, got int64"));
  }

  SECTION("unknown or repeated output") {
    CHECK_THAT(error_message([&] { session.run({{"x", golden.x}}, {"z"}); }),
               ContainsSubstring(name + ": unknown output 'z'") && ContainsSubstring("'y', 'norm'"));
    CHECK_THAT(error_message([&] { session.run({{"x", golden.x}}, {"y", "y"}); }),
               ContainsSubstring("output 'y' requested more than once"));
  }

  SECTION("the session stays usable after refusing") {
    CHECK_THROWS_AS(session.run({{"x", Tensor::float32({3, 7}, std::vector<float>(21))}}, {"y"}), Error);
    const std::vector<Tensor> out = session.run({{"x", golden.x}}, {"y"});
    CHECK(max_abs_diff(out[0].data, golden.y.data) <= kTolerance);
  }
}

TEST_CASE("int64 tensors and a symbolic axis shared by two inputs", "[onnx_session]") {
  const OnnxSession session = OnnxSession::from_file(shared_env(), tokens_path(), one_thread());
  REQUIRE(session.inputs().size() == 2);
  CHECK(session.inputs()[0].name == "ids");
  CHECK(session.inputs()[0].dtype == "int64");
  CHECK(session.inputs()[0].symbolic_dims == std::vector<std::string>{"batch", "tokens"});
  CHECK(session.inputs()[1].name == "mask");
  REQUIRE(session.outputs().size() == 2);
  CHECK(session.outputs()[0].dtype == "int64");
  CHECK(session.outputs()[1].dtype == "float32");

  const int64_t big = int64_t{1} << 40;  // beyond float32's exact range: catches a lossy path
  const Tensor ids = Tensor::int64({2, 3}, {big + 1, -7, 3, 4, 5, -big});
  const Tensor mask = Tensor::int64({2, 3}, {1, 0, 1, 1, 1, 1});
  const std::vector<Tensor> out = session.run({{"mask", mask}, {"ids", ids}}, {"masked_ids", "mask_sum"});
  REQUIRE(out.size() == 2);
  CHECK(out[0].dtype == ardy::ElementType::int64);
  CHECK(out[0].shape == std::vector<int64_t>{2, 3});
  CHECK(out[0].int64_data == std::vector<int64_t>{big + 1, 0, 3, 4, 5, -big});
  CHECK(out[1].dtype == ardy::ElementType::float32);
  CHECK(out[1].shape == std::vector<int64_t>{2});
  CHECK(out[1].data == std::vector<float>{2.0f, 3.0f});

  SECTION("inconsistent sizes for the same symbolic axis are refused") {
    const Tensor short_mask = Tensor::int64({2, 2}, {1, 1, 1, 1});
    CHECK_THAT(error_message([&] { session.run({{"ids", ids}, {"mask", short_mask}}, {}); }),
               ContainsSubstring("input 'mask': axis 1 ('tokens') is 2 but input 'ids' has 'tokens' = 3"));
  }

  SECTION("float data for an int64 input is refused") {
    const Tensor float_ids = Tensor::float32({2, 3}, std::vector<float>(6, 1.0f));
    CHECK_THAT(error_message([&] { session.run({{"ids", float_ids}, {"mask", mask}}, {}); }),
               ContainsSubstring("input 'ids': expected dtype int64, got float32"));
  }
}

TEST_CASE("sessions move, share the environment, and run from several threads", "[onnx_session]") {
  const Golden golden = load_golden();

  SECTION("move construction and assignment keep the session working") {
    OnnxSession a = OnnxSession::from_file(shared_env(), mlp_path(), one_thread());
    OnnxSession b = std::move(a);
    CHECK(max_abs_diff(b.run({{"x", golden.x}}, {"y"})[0].data, golden.y.data) <= kTolerance);
    OnnxSession c = OnnxSession::from_file(shared_env(), tokens_path(), one_thread());
    c = std::move(b);
    CHECK(c.inputs()[0].name == "x");
    CHECK(max_abs_diff(c.run({{"x", golden.x}}, {"y"})[0].data, golden.y.data) <= kTolerance);
    // A moved-from session refuses politely instead of crashing.
    CHECK_THAT(error_message([&] { a.run({{"x", golden.x}}, {"y"}); }), ContainsSubstring("moved from"));
    CHECK_THROWS_AS(a.name(), Error);
  }

  SECTION("sessions keep their environment alive") {
    auto env = OnnxEnvironment::create();
    OnnxSession first = OnnxSession::from_file(env, mlp_path(), one_thread());
    OnnxSession second = OnnxSession::from_file(env, tokens_path(), one_thread());
    env.reset();
    CHECK(max_abs_diff(first.run({{"x", golden.x}}, {"y"})[0].data, golden.y.data) <= kTolerance);
    CHECK(second.inputs().size() == 2);
  }

  SECTION("concurrent run() calls on one session agree with the golden vectors") {
    ardy::SessionOptions options;
    options.intra_op_threads = 2;
    const OnnxSession session = OnnxSession::from_file(shared_env(), mlp_path(), options);
    constexpr int kThreads = 4;
    std::vector<std::vector<Tensor>> results(kThreads);
    std::vector<std::thread> threads;
    for (int t = 0; t < kThreads; ++t) {
      threads.emplace_back([&, t] {
        for (int repeat = 0; repeat < 5; ++repeat) results[t] = session.run({{"x", golden.x}}, {"y", "norm"});
      });
    }
    for (std::thread& thread : threads) thread.join();
    for (const std::vector<Tensor>& out : results) {
      REQUIRE(out.size() == 2);
      CHECK(max_abs_diff(out[0].data, golden.y.data) <= kTolerance);
      CHECK(max_abs_diff(out[1].data, golden.norm.data) <= kTolerance);
    }
  }
}
