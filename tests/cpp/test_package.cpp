// ModelPackage: loading the tiny package from a folder and from memory, the
// values it exposes, and clear errors for malformed packages (missing or
// swapped graphs, bad model.json fields), after which loading still works.

#include <catch_amalgamated.hpp>

#include <algorithm>

#include <filesystem>
#include <functional>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "onnx_external_data.hpp"
#include "package.hpp"
#include "support/error_message.hpp"
#include "support/goldens.hpp"
#include "support/test_data.hpp"

using ardy::ModelPackage;
using ardy::PackageFiles;
using ardy_test::error_message;
using ardy_test::tiny_package_dir;
using Catch::Matchers::ContainsSubstring;
using nlohmann::json;

namespace {

const char* const kFiles[] = {"model.json",    "history.onnx", "goals.onnx",        "denoiser.onnx",
                              "decoder.onnx",  "encoder.onnx", "text_encoder.onnx", "vocab.txt"};

const PackageFiles& tiny_files() {
  static const PackageFiles files = [] {
    PackageFiles out;
    for (const char* name : kFiles) {
      const std::vector<unsigned char> bytes = ardy_test::read_bytes(tiny_package_dir() + "/" + name);
      out.emplace(name, std::string(bytes.begin(), bytes.end()));
    }
    return out;
  }();
  return files;
}

ardy::PackageOptions one_thread() {
  ardy::PackageOptions options;
  options.session.intra_op_threads = 1;
  return options;
}

size_t tiny_heads() {
  return json::parse(tiny_files().at("model.json"))["denoiser"]["heads"].get<size_t>();
}

ModelPackage load(const PackageFiles& files) { return ModelPackage::from_memory(files, "tiny", one_thread()); }

// The tiny package with model.json edited by `edit`.
PackageFiles with_model_json(const std::function<void(json&)>& edit) {
  PackageFiles files = tiny_files();
  json doc = json::parse(files.at("model.json"));
  edit(doc);
  files["model.json"] = doc.dump(1);
  return files;
}

std::string load_error(const std::function<void(json&)>& edit) {
  const PackageFiles files = with_model_json(edit);
  return error_message([&] { load(files); });
}

std::vector<float> run_golden_denoiser(const ModelPackage& package) {
  return package.denoiser().run(ardy_test::golden_denoiser_inputs(package), {"x0"}).at(0).data;
}

}  // namespace

TEST_CASE("the tiny package loads from its folder with every value from model.json", "[package]") {
  const ModelPackage package = ModelPackage::from_folder(tiny_package_dir(), one_thread());
  CHECK(package.name() == tiny_package_dir());
  CHECK(package.fps() == 20.0);
  const ardy::TokenSizes& t = package.tokens();
  CHECK(t.patch == 4);
  CHECK(t.latent_dim == 8);
  CHECK(t.token_dim == 28);
  CHECK(t.root_token_dim() == 20);
  CHECK(t.window == 10);
  CHECK(t.max_history == 8);
  CHECK(t.max_future == 4);
  CHECK(t.goal_dim == 1032);
  CHECK(package.layout().feature_size == 258);
  CHECK(package.layout() == ardy::FeatureLayout::ardy_default(21, 4));
  CHECK(package.skeleton().joint_count() == 21);
  CHECK(package.skeleton().name(12) == "Hand_R");
  CHECK(package.skeleton().parent(12) == 11);
  CHECK(package.skeleton().offset(1).y == Catch::Approx(0.1f));
  CHECK(package.contact_joints() == std::vector<std::string>{"Foot_L", "Toes_L", "Foot_R", "Toes_R"});
  CHECK(package.feature_normalization().size() == 258);
  CHECK(package.latent_normalization().size() == 8);
  CHECK(package.schedule().num_steps() == 10);
  CHECK(package.schedule().alphas_cumprod[0] == Catch::Approx(0.972092737));
  CHECK(package.sampling_defaults().steps == 4);
  CHECK(package.sampling_defaults().w_text == 2.0f);
  CHECK(package.sampling_defaults().w_con == 2.0f);
  CHECK(package.sampling_defaults().decode_context_tokens == 4);
  CHECK(package.sampling_defaults().path_guidance_scale == 1.0f);
  CHECK(package.sampling_defaults().text_only_guidance_scale == 1.0f);
  CHECK(package.text_embedding_size() == 8);
  CHECK(package.text_encoder().embedding_size() == 8);
  CHECK(package.text_settings().tokenizer.max_tokens == 128);
  CHECK(package.graph_spec("denoiser").inputs.size() == 12);
  CHECK(package.denoiser().find_input("x_t") != nullptr);
  CHECK(package.denoiser().find_input("history_kv") != nullptr);
  CHECK(package.history().find_output("history_kv") != nullptr);
  CHECK(package.goals().find_output("future_embedding") != nullptr);
  CHECK(package.denoiser().find_input("window_goal") == nullptr);  // the goals graph reads the goals
  const ardy::DenoiserSizes& sizes = package.denoiser_sizes();
  CHECK(sizes.two_stage);
  CHECK_FALSE(sizes.condition_modulation);  // absent from the tiny package's model.json
  CHECK(load(with_model_json([](json& d) { d["denoiser"]["condition_modulation"] = true; }))
            .denoiser_sizes()
            .condition_modulation);
  CHECK(sizes.width % sizes.heads == 0);
  CHECK(package.history().outputs()[0].shape ==
        std::vector<int64_t>{-1, int64_t(2 * sizes.layers), 2, int64_t(sizes.heads), -1, int64_t(sizes.head_dim())});
  CHECK_THAT(error_message([&] { package.graph_spec("planner"); }), ContainsSubstring("no graph 'planner'"));
}

TEST_CASE("a package from memory buffers behaves like the folder", "[package]") {
  const ModelPackage from_memory = load(tiny_files());
  const ModelPackage from_folder = ModelPackage::from_folder(tiny_package_dir(), one_thread());
  CHECK(run_golden_denoiser(from_memory) == run_golden_denoiser(from_folder));
  CHECK(from_memory.text_encoder().encode("a person walks") == from_folder.text_encoder().encode("a person walks"));
  CHECK(from_memory.name() == "tiny");
  // Views over bytes the caller owns work too.
  ardy::PackageFileViews views;
  for (const auto& [name, bytes] : tiny_files()) views.emplace(name, ardy::ByteView{bytes.data(), bytes.size()});
  ModelPackage from_views = ModelPackage::from_memory(views, "views", one_thread());
  CHECK(from_views.tokens().token_dim == 28);
  // A moved package keeps working; the moved-from one says so.
  ModelPackage moved = std::move(from_views);
  CHECK(moved.tokens().window == 10);
  CHECK_THAT(error_message([&] { from_views.tokens(); }), ContainsSubstring("moved from"));
}

TEST_CASE("a package read through a file reader loads only what model.json names", "[package]") {
  const ardy::PackageFiles files = tiny_files();
  std::vector<std::string> asked;
  const ardy::PackageFileReader read = [&](const std::string& file) {
    asked.push_back(file);
    const auto it = files.find(file);
    if (it == files.end()) throw ardy::Error("res://tiny/" + file + ": file not found");
    return it->second;
  };
  const ModelPackage package = ModelPackage::from_reader(read, "res://tiny", one_thread());
  const ModelPackage from_folder = ModelPackage::from_folder(tiny_package_dir(), one_thread());
  CHECK(run_golden_denoiser(package) == run_golden_denoiser(from_folder));
  CHECK(asked.front() == "model.json");
  CHECK(std::find(asked.begin(), asked.end(), "goldens.bin") == asked.end());
  CHECK(asked.size() == 8);  // model.json, six graphs, vocab.txt
  // A reader that fails names the file; nothing is left half-loaded.
  const ardy::PackageFileReader broken = [&](const std::string& file) -> std::string {
    if (file == "decoder.onnx") throw ardy::Error("res://tiny/decoder.onnx: file not found");
    return files.at(file);
  };
  CHECK_THAT(error_message([&] { ModelPackage::from_reader(broken, "res://tiny", one_thread()); }),
             ContainsSubstring("decoder.onnx: file not found"));
}

TEST_CASE("missing files are named", "[package][errors]") {
  PackageFiles files = tiny_files();
  files.erase("decoder.onnx");
  CHECK_THAT(error_message([&] { load(files); }),
             ContainsSubstring("tiny/decoder.onnx: file not given (expected an ONNX model") &&
                 ContainsSubstring("graph 'decoder'"));
  files = tiny_files();
  files.erase("vocab.txt");
  CHECK_THAT(error_message([&] { load(files); }), ContainsSubstring("tiny/vocab.txt: file not given"));
  files = tiny_files();
  files.erase("model.json");
  CHECK_THAT(error_message([&] { load(files); }), ContainsSubstring("tiny/model.json: file not given"));

  // The same from a folder.
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "ardy_test_package_missing";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  for (const char* name : kFiles) {
    if (std::string(name) == "decoder.onnx") continue;
    std::filesystem::copy_file(tiny_package_dir() + "/" + name, dir / name);
  }
  CHECK_THAT(error_message([&] { ModelPackage::from_folder(dir.string(), one_thread()); }),
             ContainsSubstring((dir / "decoder.onnx").string() + ": file not found (expected an ONNX model)") &&
                 ContainsSubstring("graphs.decoder.file"));
  std::filesystem::remove_all(dir);
  CHECK_THAT(error_message([&] { ModelPackage::from_folder(dir.string(), one_thread()); }),
             ContainsSubstring("not a folder"));
}

TEST_CASE("a swapped graph is a signature mismatch naming the graph and the input", "[package][errors]") {
  PackageFiles files = tiny_files();
  std::swap(files.at("decoder.onnx"), files.at("encoder.onnx"));
  const std::string message = error_message([&] { load(files); });
  CHECK_THAT(message, ContainsSubstring("tiny/decoder.onnx (graph 'decoder'): signature mismatch") &&
                          ContainsSubstring("declares input 'tokens' float32 [batch, tokens, 28]") &&
                          ContainsSubstring("its inputs: 'body'"));
  files = tiny_files();
  files.at("text_encoder.onnx") = files.at("denoiser.onnx");
  CHECK_THAT(error_message([&] { load(files); }),
             ContainsSubstring("(graph 'text_encoder'): signature mismatch") && ContainsSubstring("'input_ids'"));
  files = tiny_files();
  files.at("encoder.onnx") = "not an onnx file";
  CHECK_THAT(error_message([&] { load(files); }), ContainsSubstring("tiny/encoder.onnx: not a valid ONNX model"));
}

TEST_CASE("model.json fields are validated with the field, the expected and the found value", "[package][errors]") {
  CHECK_THAT(load_error([](json& d) { d["format_version"] = 3; }),
             ContainsSubstring("model.json: format_version is 3, expected 2"));
  // A package from before the history graph says how to re-export it.
  CHECK_THAT(load_error([](json& d) { d["format_version"] = 1; }),
             ContainsSubstring("format_version is 1, expected 2") &&
                 ContainsSubstring("'ardy-export recover-checkpoint' then 'ardy-export export'"));
  CHECK_THAT(load_error([](json& d) { d["denoiser"]["heads"] = 3; }),
             ContainsSubstring("denoiser.heads is 3, expected a divisor of denoiser.width"));
  CHECK_THAT(load_error([](json& d) { d["denoiser"]["history_self_only"] = false; }),
             ContainsSubstring("denoiser.history_self_only is false, expected true"));
  CHECK_THAT(load_error([](json& d) { d["denoiser"]["condition_modulation"] = "yes"; }),
             ContainsSubstring("denoiser.condition_modulation must be true or false, found \"yes\""));
  CHECK_THAT(load_error([](json& d) { d["denoiser"].erase("layers"); }),
             ContainsSubstring("missing field denoiser.layers"));
  CHECK_THAT(load_error([](json& d) { d["format"] = "something-else"; }),
             ContainsSubstring("model.json: format is 'something-else', expected 'ardy-model-package'"));
  CHECK_THAT(load_error([](json& d) { d["tokens"]["token_dim"] = 30; }),
             ContainsSubstring("model.json: tokens.token_dim is 30, expected 5*patch + latent_dim = 28"));
  CHECK_THAT(load_error([](json& d) { d["tokens"]["goal_dim"] = 1000; }),
             ContainsSubstring("model.json: tokens.goal_dim is 1000, expected patch * features.size = 1032"));
  CHECK_THAT(load_error([](json& d) { d["normalization"].erase("latent_std"); }),
             ContainsSubstring("model.json: missing field normalization.latent_std"));
  CHECK_THAT(load_error([](json& d) { d.erase("tokens"); }), ContainsSubstring("model.json: missing field tokens"));
  CHECK_THAT(load_error([](json& d) { d["tokens"]["patch"] = "four"; }),
             ContainsSubstring("model.json: tokens.patch must be an integer, found \"four\""));
  CHECK_THAT(load_error([](json& d) { d["normalization"]["mean"].erase(0); }),
             ContainsSubstring("model.json: normalization.mean has 257 entries, expected 258"));
  CHECK_THAT(load_error([](json& d) { d["normalization"]["std"][7] = 0.0; }),
             ContainsSubstring("std[7] is 0.000000; standard deviations must be finite and positive"));
  CHECK_THAT(load_error([](json& d) { d["normalization"]["latent_mean"] = json::array({1, 2}); }),
             ContainsSubstring("normalization.latent_mean has 2 entries, expected 8"));
  CHECK_THAT(load_error([](json& d) { d["skeleton"]["parents"][3] = 5; }),
             ContainsSubstring("skeleton: joint 3 ('Neck') has parent 5; a parent must be an earlier joint"));
  CHECK_THAT(load_error([](json& d) { d["skeleton"]["parents"].erase(20); }),
             ContainsSubstring("skeleton.parents has 20 entries, expected 21"));
  CHECK_THAT(load_error([](json& d) { d["skeleton"]["rest_offsets"][2] = json::array({0, 1}); }),
             ContainsSubstring("skeleton.rest_offsets[2] must be [x, y, z]"));
  CHECK_THAT(load_error([](json& d) { d["features"]["slices"]["rotation_6d"] = json::array({5, 130}); }),
             ContainsSubstring("features.slices: feature layout: 'rotation_6d'"));
  CHECK_THAT(load_error([](json& d) { d["features"]["size"] = 259; }),
             ContainsSubstring("features.size is 259, expected 258"));
  CHECK_THAT(load_error([](json& d) { d["features"]["contact_joints"][1] = "Toe_L"; }),
             ContainsSubstring("features.contact_joints[1] is 'Toe_L', which is not a joint"));
  CHECK_THAT(load_error([](json& d) { d["diffusion"]["alphas_cumprod"].erase(9); }),
             ContainsSubstring("diffusion.alphas_cumprod has 9 entries, expected 10"));
  CHECK_THAT(load_error([](json& d) { d["diffusion"]["alphas_cumprod"][3] = 1.5; }),
             ContainsSubstring("diffusion.alphas_cumprod[3] is 1.5, expected 0 < value < 1"));
  CHECK_THAT(load_error([](json& d) { d["diffusion"]["prediction"] = "eps"; }),
             ContainsSubstring("diffusion.prediction is 'eps', expected 'x0'"));
  CHECK_THAT(load_error([](json& d) { d["sampling"]["default_steps"] = 0; }),
             ContainsSubstring("sampling.default_steps is 0, expected 1..10"));
  CHECK_THAT(load_error([](json& d) { d["sampling"]["w_text"] = "two"; }),
             ContainsSubstring("sampling.w_text must be a number"));
  CHECK_THAT(load_error([](json& d) { d["sampling"]["path_guidance_scale"] = 0; }),
             ContainsSubstring("sampling.path_guidance_scale is 0.0, expected a number in (0, 1]"));
  CHECK_THAT(load_error([](json& d) { d["sampling"]["path_guidance_scale"] = 1.5; }),
             ContainsSubstring("sampling.path_guidance_scale is 1.5, expected a number in (0, 1]"));
  CHECK_THAT(load_error([](json& d) { d["sampling"]["text_only_guidance_scale"] = 0; }),
             ContainsSubstring("sampling.text_only_guidance_scale is 0.0, expected a number in (0, 4]"));
  CHECK_THAT(load_error([](json& d) { d["sampling"]["text_only_guidance_scale"] = 4.5; }),
             ContainsSubstring("sampling.text_only_guidance_scale is 4.5, expected a number in (0, 4]"));
  CHECK_THAT(load_error([](json& d) { d["text"]["special_tokens"]["unk"]["id"] = 7; }),
             ContainsSubstring("text.special_tokens.unk.id is 7, but") && ContainsSubstring("at id 100"));
  CHECK_THAT(
      load_error([](json& d) { d["text"]["embedding_size"] = 16; }),
      ContainsSubstring("graphs.denoiser.inputs 'text_embedding' is float32 [batch, 8], expected float32 [B, 16"));
}

TEST_CASE("model.json graph signatures are checked against the contract and the graphs", "[package][errors]") {
  // model.json disagrees with the contract (sizes).
  CHECK_THAT(load_error([](json& d) { d["graphs"]["denoiser"]["inputs"][0]["shape"][2] = 30; }),
             ContainsSubstring("graphs.denoiser.inputs 'x_t' is float32 [batch, 10, 30], expected float32 [B, 10 "
                               "(tokens.window), 28 (tokens.token_dim)]"));
  CHECK_THAT(load_error([](json& d) { d["graphs"]["denoiser"]["inputs"].erase(3); }),
             ContainsSubstring("graphs.denoiser.inputs has no input 'text_keep'"));
  CHECK_THAT(load_error([](json& d) { d["graphs"]["denoiser"]["inputs"][5]["shape"][1] = "future"; }),
             ContainsSubstring("'history_mask' names axis 1 'future', but another input names the same axis (H) "
                               "'history'"));
  // The history graph's keys and values have the denoiser's sizes.
  CHECK_THAT(load_error([](json& d) { d["graphs"]["history"]["outputs"][0]["shape"][3] = 4; }),
             ContainsSubstring("graphs.history.outputs 'history_kv'") &&
                 ContainsSubstring("(axis 3 must be " + std::to_string(tiny_heads()) + ")"));
  CHECK_THAT(load_error([](json& d) { d["denoiser"]["layers"] = 7; }),
             ContainsSubstring("graphs.history.outputs 'history_kv'") &&
                 ContainsSubstring("(stages * denoiser.layers)"));
  CHECK_THAT(load_error([](json& d) { d["graphs"]["decoder"]["outputs"][0]["dtype"] = "float64"; }),
             ContainsSubstring("graphs.decoder.outputs 'body' is float64"));
  // model.json agrees with the contract but not with the graph file.
  CHECK_THAT(load_error([](json& d) { d["graphs"]["decoder"]["inputs"][0]["shape"][1] = "frames"; }),
             ContainsSubstring("decoder.onnx (graph 'decoder'): signature mismatch: input 'tokens' is float32 "
                               "[batch, tokens, 28] in the graph, but") &&
                 ContainsSubstring("declares float32 [batch, frames, 28]"));
  CHECK_THAT(load_error([](json& d) { d["graphs"]["encoder"]["outputs"][0]["name"] = "codes"; }),
             ContainsSubstring("graphs.encoder.outputs has no output 'latent'"));
}

TEST_CASE("broken model.json text and the package stays loadable afterwards", "[package][errors]") {
  PackageFiles files = tiny_files();
  files["model.json"] = "{ not json";
  CHECK_THAT(error_message([&] { load(files); }), ContainsSubstring("tiny/model.json: not valid JSON"));
  files["model.json"] = "[1, 2]";
  CHECK_THAT(error_message([&] { load(files); }), ContainsSubstring("expected a JSON object"));
  // Nothing is left behind by the failures above.
  const ModelPackage package = load(tiny_files());
  CHECK(package.tokens().window == 10);
  CHECK(run_golden_denoiser(package).size() == 3 * 10 * 28);
}

// --- untrusted packages: file names and external data -----------------------------------------

namespace {

// Protobuf wire format, enough to craft ONNX models in the tests.
std::string varint(uint64_t v) {
  std::string out;
  do {
    out.push_back(static_cast<char>((v & 0x7f) | (v > 0x7f ? 0x80 : 0)));
    v >>= 7;
  } while (v);
  return out;
}
std::string field_bytes(int field, const std::string& payload) {
  return varint(uint64_t(field) << 3 | 2) + varint(payload.size()) + payload;
}
std::string field_varint(int field, uint64_t v) { return varint(uint64_t(field) << 3) + varint(v); }

// TensorProto "W" with its data in `location` (data_location EXTERNAL).
std::string external_tensor(const std::string& location) {
  return field_bytes(8, "W") + field_bytes(13, field_bytes(1, "location") + field_bytes(2, location)) +
         field_varint(14, 1);
}
// ModelProto { ir_version, graph { initializer } }.
std::string model_with_initializer(const std::string& tensor) {
  return field_varint(1, 8) + field_bytes(7, field_bytes(2, "g") + field_bytes(5, tensor));
}
// The tensor hidden in a subgraph: graph { node { attribute { g { initializer } } } }.
std::string model_with_nested_tensor(const std::string& tensor) {
  const std::string subgraph = field_bytes(5, tensor);
  const std::string attribute = field_bytes(1, "then_branch") + field_bytes(6, subgraph);
  return field_varint(1, 8) + field_bytes(7, field_bytes(1, field_bytes(5, attribute)));
}

std::string load_with_denoiser(const std::string& bytes) {
  PackageFiles files = tiny_files();
  files["denoiser.onnx"] = bytes;
  return error_message([&] { load(files); });
}

}  // namespace

TEST_CASE("file names in model.json must stay inside the package", "[package][errors][security]") {
  const auto with_file = [](const std::string& key, const std::string& name) {
    return load_error([&](json& m) {
      if (key == "vocab") {
        m["text"]["vocab"] = name;
      } else {
        m["graphs"][key]["file"] = name;
      }
    });
  };
  CHECK_THAT(with_file("denoiser", "../denoiser.onnx"),
             ContainsSubstring("model.json: graphs.denoiser.file is '../denoiser.onnx', which has a '..' component") &&
                 ContainsSubstring("expected a file name inside the package"));
  CHECK_THAT(with_file("denoiser", "graphs/../../x.onnx"), ContainsSubstring("has a '..' component"));
  CHECK_THAT(with_file("decoder", "/etc/passwd"),
             ContainsSubstring("graphs.decoder.file is '/etc/passwd', which is an absolute path"));
  CHECK_THAT(with_file("encoder", "..\\encoder.onnx"), ContainsSubstring("contains a backslash"));
  CHECK_THAT(with_file("encoder", "C:encoder.onnx"), ContainsSubstring("contains ':' (a drive letter"));
  CHECK_THAT(with_file("history", ""), ContainsSubstring("graphs.history.file is '', which is empty"));
  CHECK_THAT(with_file("history", "a//history.onnx"), ContainsSubstring("empty or '.' path component"));
  CHECK_THAT(with_file("vocab", "../../vocab.txt"),
             ContainsSubstring("text.vocab is '../../vocab.txt', which has a '..' component"));
  // A name that merely contains two dots is a file name like any other.
  CHECK_THAT(with_file("denoiser", "denoiser..v2.onnx"), ContainsSubstring("denoiser..v2.onnx: file not given"));
}

TEST_CASE("graphs with external data are refused from memory; from a folder, outside it", "[package][errors][security]") {
  // From memory: any external data (ONNX Runtime would resolve it against the working folder).
  CHECK_THAT(load_with_denoiser(model_with_initializer(external_tensor("weights.bin"))),
             ContainsSubstring("tiny/denoiser.onnx: tensor 'W' keeps its data in external file 'weights.bin'; a package "
                               "loaded from memory must embed every tensor") &&
                 ContainsSubstring("graph 'denoiser'"));
  CHECK_THAT(load_with_denoiser(model_with_nested_tensor(external_tensor("/etc/passwd"))),
             ContainsSubstring("tensor 'W' keeps its data in external file '/etc/passwd'"));
  // Through a reader, the same.
  PackageFiles files = tiny_files();
  files["encoder.onnx"] = model_with_initializer(external_tensor("../secret.bin"));
  CHECK_THAT(error_message([&] {
               ModelPackage::from_reader([&](const std::string& f) { return files.at(f); }, "reader", one_thread());
             }),
             ContainsSubstring("reader/encoder.onnx: tensor 'W' keeps its data in external file '../secret.bin'"));

  // From a folder: a location must be a relative path inside it.
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "ardy_test_package_external";
  const auto folder_error = [&](const std::string& denoiser) {
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    for (const char* name : kFiles) std::filesystem::copy_file(tiny_package_dir() + "/" + name, dir / name);
    std::ofstream(dir / "denoiser.onnx", std::ios::binary | std::ios::trunc) << denoiser;
    return error_message([&] { ModelPackage::from_folder(dir.string(), one_thread()); });
  };
  CHECK_THAT(folder_error(model_with_initializer(external_tensor("../../etc/shadow"))),
             ContainsSubstring((dir / "denoiser.onnx").string() +
                               ": tensor 'W' keeps its data in external file '../../etc/shadow', whose location has a "
                               "'..' component (leaves the package)"));
  CHECK_THAT(folder_error(model_with_nested_tensor(external_tensor("/etc/shadow"))),
             ContainsSubstring("whose location is an absolute path"));
  CHECK_THAT(folder_error(model_with_initializer(external_tensor("C:\\weights.bin"))),
             ContainsSubstring("whose location contains a backslash"));
  // data_location EXTERNAL without a location is refused too (it cannot be checked).
  CHECK_THAT(folder_error(model_with_initializer(field_bytes(8, "W") + field_varint(14, 1))),
             ContainsSubstring("tensor 'W' keeps its data in external file '', whose location is empty"));
  // A relative location inside the folder passes the check (this crafted graph then fails in ONNX Runtime).
  CHECK_THAT(folder_error(model_with_initializer(external_tensor("weights/denoiser.bin"))),
             !ContainsSubstring("keeps its data in external file"));
  // A symbolic link inside the folder that leads out of it, as a graph and as external data.
  const std::filesystem::path outside = std::filesystem::temp_directory_path() / "ardy_test_package_outside.bin";
  std::ofstream(outside) << "secret";
  folder_error(model_with_initializer(external_tensor("link.bin")));
  std::filesystem::create_symlink(outside, dir / "link.bin");
  CHECK_THAT(error_message([&] { ModelPackage::from_folder(dir.string(), one_thread()); }),
             ContainsSubstring((dir / "denoiser.onnx").string() + ": 'link.bin' resolves to ") &&
                 ContainsSubstring("outside the package folder (a symbolic link?)"));
  std::filesystem::remove(dir / "vocab.txt");
  std::filesystem::create_symlink(outside, dir / "vocab.txt");
  std::filesystem::copy_file(tiny_package_dir() + "/denoiser.onnx", dir / "denoiser.onnx",
                             std::filesystem::copy_options::overwrite_existing);
  CHECK_THAT(error_message([&] { ModelPackage::from_folder(dir.string(), one_thread()); }),
             ContainsSubstring((dir / "vocab.txt").string() + ": 'vocab.txt' resolves to ") &&
                 ContainsSubstring("outside the package folder"));
  std::filesystem::remove(outside);
  std::filesystem::remove_all(dir);
}

TEST_CASE("the external-data scanner refuses malformed bytes and finds nothing in real graphs", "[package][security]") {
  namespace scan = ardy::onnx_scan;
  for (const char* name : {"history.onnx", "denoiser.onnx", "decoder.onnx", "encoder.onnx", "text_encoder.onnx"}) {
    const std::string& bytes = tiny_files().at(name);
    CHECK(scan::external_tensors(bytes.data(), bytes.size(), name).empty());
  }
  const std::string good = model_with_nested_tensor(external_tensor("w.bin"));
  const auto found = scan::external_tensors(good.data(), good.size(), "m.onnx");
  REQUIRE(found.size() == 1);
  CHECK(found[0].tensor == "W");
  CHECK(found[0].location == "w.bin");
  // Two location entries: both are checked, whichever ONNX Runtime would use.
  const std::string twice = model_with_initializer(external_tensor("w.bin") +
                                                   field_bytes(13, field_bytes(1, "location") + field_bytes(2, "../x")));
  const auto both = scan::external_tensors(twice.data(), twice.size(), "twice.onnx");
  REQUIRE(both.size() == 2);
  CHECK(both[1].location == "../x");
  // Truncated: every prefix is either refused or fine, never read past its end.
  for (size_t n = 1; n < good.size(); ++n) {
    const std::string cut = good.substr(0, n);
    try {
      scan::external_tensors(cut.data(), cut.size(), "cut.onnx");
    } catch (const ardy::Error& e) {
      CHECK_THAT(std::string(e.what()), ContainsSubstring("cut.onnx: not a valid ONNX model ("));
    }
  }
  const std::string group = varint(7 << 3 | 3);
  CHECK_THAT(error_message([&] { scan::external_tensors(group.data(), group.size(), "g.onnx"); }),
             ContainsSubstring("g.onnx: not a valid ONNX model (wire type 3"));
  // Subgraphs nested past the bound.
  std::string deep = field_bytes(5, external_tensor("w.bin"));
  for (int i = 0; i < scan::kMaxDepth / 3 + 1; ++i) deep = field_bytes(1, field_bytes(5, field_bytes(6, deep)));
  const std::string model = field_bytes(7, deep);
  CHECK_THAT(error_message([&] { scan::external_tensors(model.data(), model.size(), "deep.onnx"); }),
             ContainsSubstring("nested deeper than 64"));
  CHECK(scan::unsafe_path_reason("weights/w.bin").empty());
  CHECK(scan::unsafe_path_reason("w..bin").empty());
  CHECK(scan::unsafe_path_reason("..w.bin").empty());  // an ordinary name (the fuzzer's first finding was a
                                                        // harness that thought otherwise)
  CHECK(scan::unsafe_path_reason("../w.bin") == "has a '..' component (leaves the package)");
  CHECK(scan::unsafe_path_reason("./w.bin") == "has an empty or '.' path component");
  CHECK(scan::unsafe_path_reason("w.bin/..") == "has a '..' component (leaves the package)");
}
