#pragma once
// MotionGenerator: the node game developers drop into a scene. It animates a
// Skeleton3D with the ARDY model; this first version loads the model's graphs
// (through FileAccess, so packed games work) and drives bones directly.
#include "godot/class_db.hpp"

#include "onnx_session.hpp"
#include "package.hpp"

#include <memory>
#include <string>
#include <vector>

namespace ardy {

class MotionGenerator : public godot::Node3D {
	GDCLASS(MotionGenerator, godot::Node3D)

public:
	MotionGenerator() = default;
	~MotionGenerator() override = default;

	void set_model_path(const godot::String &path);
	godot::String get_model_path() const;
	void set_skeleton(const godot::NodePath &path);
	godot::NodePath get_skeleton() const;
	void set_prompt(const godot::String &prompt);
	godot::String get_prompt() const;
	void set_playing(bool playing);
	bool is_playing() const;

	// Loads the model package at `path` (a folder with model.json; a single
	// .onnx file loads just that graph, to check it; empty means model_path).
	// Returns false and emits generation_failed with the reason when anything
	// is wrong; the previous model stays loaded.
	bool load_model(const godot::String &path);
	bool is_model_loaded() const;
	godot::PackedStringArray get_loaded_graphs() const;
	// The model skeleton's joints, in the model's order (empty without a package).
	godot::PackedStringArray get_joint_names() const;
	godot::String get_last_error() const;

	// Sets the local rotation of skeleton bones by name ({"Hips": Quaternion});
	// returns how many were applied. Unknown names are reported, not applied.
	int64_t apply_joint_rotations(const godot::Dictionary &rotations);

	void _ready();
	godot::PackedStringArray _get_configuration_warnings() const;

protected:
	static void _bind_methods();

private:
	godot::Skeleton3D *find_skeleton() const;
	void fail(const std::string &message);

	godot::String model_path_;
	godot::NodePath skeleton_path_;
	godot::String prompt_;
	bool playing_ = false;

	std::shared_ptr<OnnxEnvironment> onnx_environment_;
	std::shared_ptr<const ModelPackage> package_;
	std::vector<OnnxSession> lone_graphs_;  // a single .onnx file loaded on its own
	std::vector<std::string> graph_names_;
	std::string last_error_;
};

} // namespace ardy
