#include "motion_generator.hpp"

#include "godot/error_macros.hpp"
#include "godot/ref.hpp"

#include <algorithm>

using namespace godot;

namespace ardy {

namespace {

bool ends_with(const std::string &text, const std::string &suffix) {
	return text.size() >= suffix.size() && text.compare(text.size() - suffix.size(), suffix.size(), suffix) == 0;
}

// Reads a whole file through the engine, so paths inside an exported .pck work.
std::string read_engine_file(const std::string &path) {
	Ref<FileAccess> file = FileAccess::open(String(path), FileAccess::READ);
	if (file.is_null()) {
		throw Error("cannot open '" + path + "': " + error_string(FileAccess::get_open_error()).utf8());
	}
	const uint64_t length = file->get_length();
	const PackedByteArray bytes = file->get_buffer(static_cast<int64_t>(length));
	if (static_cast<uint64_t>(bytes.size()) != length || file->get_error() != OK) {
		throw Error("cannot read '" + path + "': " + error_string(file->get_error()).utf8());
	}
	return std::string(reinterpret_cast<const char *>(bytes.ptr()), static_cast<size_t>(bytes.size()));
}

std::string file_name(const std::string &path) {
	const size_t slash = path.find_last_of('/');
	return slash == std::string::npos ? path : path.substr(slash + 1);
}

} // namespace

void MotionGenerator::set_model_path(const String &path) {
	model_path_ = path;
	update_configuration_warnings();
}

String MotionGenerator::get_model_path() const {
	return model_path_;
}

void MotionGenerator::set_skeleton(const NodePath &path) {
	skeleton_path_ = path;
	update_configuration_warnings();
}

NodePath MotionGenerator::get_skeleton() const {
	return skeleton_path_;
}

void MotionGenerator::set_prompt(const String &prompt) {
	prompt_ = prompt;
}

String MotionGenerator::get_prompt() const {
	return prompt_;
}

void MotionGenerator::set_playing(bool playing) {
	playing_ = playing;
}

bool MotionGenerator::is_playing() const {
	return playing_;
}

bool MotionGenerator::load_model(const String &path) {
	const std::string requested = path.is_empty() ? model_path_.utf8() : path.utf8();
	if (requested.empty()) {
		fail("load_model: no model path given and model_path is empty");
		return false;
	}
	try {
		if (!onnx_environment_) {
			onnx_environment_ = OnnxEnvironment::create();
		}
		PackageOptions options;
		options.environment = onnx_environment_;
		if (ends_with(requested, ".onnx")) {
			const std::string bytes = read_engine_file(requested);
			if (bytes.empty()) {
				throw Error("'" + requested + "' is empty, not an ONNX graph");
			}
			std::vector<OnnxSession> graphs;
			graphs.push_back(OnnxSession::from_memory(onnx_environment_, bytes.data(), bytes.size(), requested));
			lone_graphs_ = std::move(graphs);
			package_.reset();
			graph_names_ = { file_name(requested) };
		} else {
			const std::string folder = ends_with(requested, "/") ? requested : requested + "/";
			const PackageFileReader read = [&folder](const std::string &file) { return read_engine_file(folder + file); };
			auto package = std::make_shared<const ModelPackage>(ModelPackage::from_reader(read, requested, options));
			std::vector<std::string> names;
			for (const char *key : { "denoiser", "decoder", "encoder", "text_encoder" }) {
				names.push_back(package->graph_spec(key).file);
			}
			std::sort(names.begin(), names.end());
			package_ = std::move(package);
			lone_graphs_.clear();
			graph_names_ = std::move(names);
		}
	} catch (const std::exception &failure) {
		fail(std::string("load_model: ") + failure.what());
		return false;
	}
	last_error_.clear();
	emit_signal("model_loaded", String(requested));
	return true;
}

bool MotionGenerator::is_model_loaded() const {
	return package_ != nullptr || !lone_graphs_.empty();
}

PackedStringArray MotionGenerator::get_loaded_graphs() const {
	PackedStringArray names;
	for (const std::string &name : graph_names_) {
		names.push_back(String(name));
	}
	return names;
}

PackedStringArray MotionGenerator::get_joint_names() const {
	PackedStringArray names;
	if (package_) {
		for (const std::string &name : package_->skeleton().names()) {
			names.push_back(String(name));
		}
	}
	return names;
}

String MotionGenerator::get_last_error() const {
	return String(last_error_);
}

int64_t MotionGenerator::apply_joint_rotations(const Dictionary &rotations) {
	Skeleton3D *skeleton = find_skeleton();
	if (skeleton == nullptr) {
		fail("apply_joint_rotations: skeleton does not point to a Skeleton3D (" + String(skeleton_path_).utf8() + ")");
		return 0;
	}
	const Array joints = rotations.keys();
	int64_t applied = 0;
	std::string unknown;
	for (int64_t i = 0; i < joints.size(); ++i) {
		const Variant joint = joints[i];
		const Variant rotation = rotations.get(joint);
		if (joint.get_type() != Variant::STRING && joint.get_type() != Variant::STRING_NAME) {
			unknown += unknown.empty() ? "(non-text key)" : ", (non-text key)";
			continue;
		}
		const String name = joint;
		const int32_t bone = skeleton->find_bone(name);
		if (bone < 0 || rotation.get_type() != Variant::QUATERNION) {
			unknown += (unknown.empty() ? "" : ", ") + name.utf8();
			continue;
		}
		skeleton->set_bone_pose_rotation(bone, rotation);
		++applied;
	}
	if (!unknown.empty()) {
		fail("apply_joint_rotations: no bone or no Quaternion for: " + unknown);
	}
	return applied;
}

void MotionGenerator::_ready() {
	if (Engine::get_singleton()->is_editor_hint()) {
		return;
	}
	if (playing_ && !model_path_.is_empty() && !is_model_loaded()) {
		load_model(String());
	}
}

PackedStringArray MotionGenerator::_get_configuration_warnings() const {
	PackedStringArray warnings;
	if (model_path_.is_empty()) {
		warnings.push_back(String("Set model_path to a model package folder (the default model is in res://addons/ardy/models/default)."));
	}
	if (skeleton_path_.is_empty()) {
		warnings.push_back(String("Set skeleton to the Skeleton3D this node animates."));
	} else if (is_inside_tree() && find_skeleton() == nullptr) {
		warnings.push_back(String("skeleton does not point to a Skeleton3D."));
	}
	return warnings;
}

Skeleton3D *MotionGenerator::find_skeleton() const {
	if (skeleton_path_.is_empty()) {
		return nullptr;
	}
	return Object::cast_to<Skeleton3D>(get_node_or_null(skeleton_path_));
}

void MotionGenerator::fail(const std::string &message) {
	last_error_ = message;
	ERR_PRINT("MotionGenerator: " + message);
	emit_signal("generation_failed", String(message));
}

void MotionGenerator::_bind_methods() {
	ClassDB::bind_method(D_METHOD("set_model_path", "path"), &MotionGenerator::set_model_path);
	ClassDB::bind_method(D_METHOD("get_model_path"), &MotionGenerator::get_model_path);
	ClassDB::bind_method(D_METHOD("set_skeleton", "path"), &MotionGenerator::set_skeleton);
	ClassDB::bind_method(D_METHOD("get_skeleton"), &MotionGenerator::get_skeleton);
	ClassDB::bind_method(D_METHOD("set_prompt", "prompt"), &MotionGenerator::set_prompt);
	ClassDB::bind_method(D_METHOD("get_prompt"), &MotionGenerator::get_prompt);
	ClassDB::bind_method(D_METHOD("set_playing", "playing"), &MotionGenerator::set_playing);
	ClassDB::bind_method(D_METHOD("is_playing"), &MotionGenerator::is_playing);
	ClassDB::bind_method(D_METHOD("load_model", "path"), &MotionGenerator::load_model, DEFVAL(String()));
	ClassDB::bind_method(D_METHOD("is_model_loaded"), &MotionGenerator::is_model_loaded);
	ClassDB::bind_method(D_METHOD("get_loaded_graphs"), &MotionGenerator::get_loaded_graphs);
	ClassDB::bind_method(D_METHOD("get_joint_names"), &MotionGenerator::get_joint_names);
	ClassDB::bind_method(D_METHOD("get_last_error"), &MotionGenerator::get_last_error);
	ClassDB::bind_method(D_METHOD("apply_joint_rotations", "rotations"), &MotionGenerator::apply_joint_rotations);

	ADD_GROUP("Model", "");
	ADD_PROPERTY(PropertyInfo(Variant::STRING, "model_path", PROPERTY_HINT_DIR), "set_model_path", "get_model_path");
	ADD_GROUP("Target", "");
	ADD_PROPERTY(PropertyInfo(Variant::NODE_PATH, "skeleton", PROPERTY_HINT_NODE_PATH_VALID_TYPES, "Skeleton3D"), "set_skeleton", "get_skeleton");
	ADD_GROUP("Generation", "");
	ADD_PROPERTY(PropertyInfo(Variant::STRING, "prompt", PROPERTY_HINT_MULTILINE_TEXT), "set_prompt", "get_prompt");
	ADD_PROPERTY(PropertyInfo(Variant::BOOL, "playing"), "set_playing", "is_playing");

	ADD_SIGNAL(MethodInfo("generation_failed", PropertyInfo(Variant::STRING, "message")));
	ADD_SIGNAL(MethodInfo("model_loaded", PropertyInfo(Variant::STRING, "path")));
}

} // namespace ardy
