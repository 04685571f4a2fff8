#pragma once
// Wrappers for the engine classes our nodes call. Bind only what is used.
#include "object.hpp"

namespace godot {

template <class T>
class Ref;

class RefCounted : public Object {
	GDENGINECLASS(RefCounted, Object)

public:
	bool init_ref();
	bool reference();
	bool unreference();
};

class Node : public Object {
	GDENGINECLASS(Node, Object)

public:
	enum {
		NOTIFICATION_ENTER_TREE = 10,
		NOTIFICATION_EXIT_TREE = 11,
		NOTIFICATION_READY = 13,
	};

	Node *get_node_or_null(const NodePath &path) const;
	bool is_inside_tree() const;
	void update_configuration_warnings();
	void set_process(bool enabled);

	// Virtual overrides: a class that declares one of these is registered for
	// it (see Node::register_virtuals).
	void _ready() {}
	void _process(double) {}
	void _physics_process(double) {}
	void _enter_tree() {}
	void _exit_tree() {}
	PackedStringArray _get_configuration_warnings() const { return {}; }

	template <class T>
	static void register_virtuals();
};

class Node3D : public Node {
	GDENGINECLASS(Node3D, Node)
};

class Skeleton3D : public Node3D {
	GDENGINECLASS(Skeleton3D, Node3D)

public:
	int32_t find_bone(const String &name) const;
	int32_t get_bone_count() const;
	String get_bone_name(int32_t bone) const;
	void set_bone_pose_rotation(int32_t bone, const Quaternion &rotation);
	void set_bone_pose_position(int32_t bone, const Vector3 &position);
	Quaternion get_bone_pose_rotation(int32_t bone) const;
	Transform3D get_bone_rest(int32_t bone) const;
};

class FileAccess : public RefCounted {
	GDENGINECLASS(FileAccess, RefCounted)

public:
	enum ModeFlags {
		READ = 1,
	};
	static Ref<FileAccess> open(const String &path, ModeFlags mode);
	static Error get_open_error();
	uint64_t get_length() const;
	PackedByteArray get_buffer(int64_t length) const;
	Error get_error() const;
};

// The Engine singleton.
class Engine : public Object {
	GDENGINECLASS(Engine, Object)

public:
	static Engine *get_singleton();
	bool is_editor_hint() const;
};

// Godot's error_string(): "File not found", ...
String error_string(Error error);

} // namespace godot
