#include "engine_classes.hpp"

#include "engine_call.hpp"
#include "memory.hpp"
#include "ref.hpp"

#include <vector>

namespace godot {

using internal::call_engine;
using internal::gde;

namespace internal {

namespace {
thread_local GDExtensionObjectPtr constructing_owner = nullptr;

template <class T>
Wrapped *make_wrapper(GDExtensionObjectPtr owner) {
	set_constructing_owner(owner);
	return memnew_tracked<T>();
}

// Most derived first, so an object gets the most specific wrapper we have.
// Every engine wrapper class must be listed here.
Wrapped *make_engine_wrapper(GDExtensionObjectPtr owner) {
	using Maker = Wrapped *(*)(GDExtensionObjectPtr);
	struct Rung {
		void *(*tag)();
		Maker make;
	};
	static const Rung ladder[] = {
		{ &Skeleton3D::get_class_tag, &make_wrapper<Skeleton3D> },
		{ &SkeletonModifier3D::get_class_tag, &make_wrapper<SkeletonModifier3D> },
		{ &CharacterBody3D::get_class_tag, &make_wrapper<CharacterBody3D> },
		{ &Path3D::get_class_tag, &make_wrapper<Path3D> },
		{ &Node3D::get_class_tag, &make_wrapper<Node3D> },
		{ &Node::get_class_tag, &make_wrapper<Node> },
		{ &FileAccess::get_class_tag, &make_wrapper<FileAccess> },
		{ &Curve3D::get_class_tag, &make_wrapper<Curve3D> },
		{ &BoneMap::get_class_tag, &make_wrapper<BoneMap> },
		{ &Animation::get_class_tag, &make_wrapper<Animation> },
		{ &Resource::get_class_tag, &make_wrapper<Resource> },
		{ &RefCounted::get_class_tag, &make_wrapper<RefCounted> },
		{ &Engine::get_class_tag, &make_wrapper<Engine> },
	};
	for (const Rung &rung : ladder) {
		if (gde.object_cast_to(owner, rung.tag()) != nullptr) {
			return rung.make(owner);
		}
	}
	return make_wrapper<Object>(owner);
}

void *create_binding(void *, void *instance) {
	return make_engine_wrapper(static_cast<GDExtensionObjectPtr>(instance));
}

void free_binding(void *, void *, void *binding) {
	memdelete(static_cast<Wrapped *>(binding));
}

GDExtensionBool reference_binding(void *, void *, GDExtensionBool) {
	return true;
}

const GDExtensionInstanceBindingCallbacks engine_wrapper_callbacks = { &create_binding, &free_binding, &reference_binding };
} // namespace

GDExtensionObjectPtr take_constructing_owner() {
	GDExtensionObjectPtr owner = constructing_owner;
	constructing_owner = nullptr;
	return owner;
}

void set_constructing_owner(GDExtensionObjectPtr owner) {
	constructing_owner = owner;
}

void *class_tag(const char *class_name) {
	StringName name(class_name);
	return gde.classdb_get_class_tag(name.native_ptr());
}

Wrapped *wrapper_of(GDExtensionObjectPtr object) {
	return static_cast<Wrapped *>(gde.object_get_instance_binding(object, gde.token, &engine_wrapper_callbacks));
}

GDExtensionMethodBindPtr method_bind(const char *class_name, const char *method, int64_t hash) {
	StringName class_string(class_name);
	StringName method_string(method);
	GDExtensionMethodBindPtr bind = gde.classdb_get_method_bind(class_string.native_ptr(), method_string.native_ptr(), hash);
	if (bind == nullptr) {
		const std::string message = std::string("engine method ") + class_name + "." + method + " not found (hash " + std::to_string(hash) + "): the engine's API differs from the one this extension was built against";
		gde.print_error(message.c_str(), __func__, __FILE__, __LINE__, false);
	}
	return bind;
}

} // namespace internal

String Object::get_class() const {
	return call_engine<String>(ARDY_ENGINE_METHOD(Object, get_class), _owner);
}

bool Object::is_class(const String &name) const {
	return call_engine<bool>(ARDY_ENGINE_METHOD(Object, is_class), _owner, name);
}

uint64_t Object::get_instance_id() const {
	return call_engine<uint64_t>(ARDY_ENGINE_METHOD(Object, get_instance_id), _owner);
}

void Object::emit_signal_variants(const Variant *values, int count) {
	std::vector<GDExtensionConstVariantPtr> pointers(static_cast<std::size_t>(count));
	for (int i = 0; i < count; ++i) {
		pointers[static_cast<std::size_t>(i)] = values[i].native_ptr();
	}
	Variant result;
	GDExtensionCallError error{};
	gde.variant_destroy(result.native_ptr());
	gde.object_method_bind_call(ARDY_ENGINE_METHOD(Object, emit_signal), _owner, pointers.data(), count, result.native_ptr(), &error);
}

bool RefCounted::init_ref() {
	return call_engine<bool>(ARDY_ENGINE_METHOD(RefCounted, init_ref), _owner);
}

bool RefCounted::reference() {
	return call_engine<bool>(ARDY_ENGINE_METHOD(RefCounted, reference), _owner);
}

bool RefCounted::unreference() {
	return call_engine<bool>(ARDY_ENGINE_METHOD(RefCounted, unreference), _owner);
}

Node *Node::get_node_or_null(const NodePath &path) const {
	return call_engine<Node *>(ARDY_ENGINE_METHOD(Node, get_node_or_null), _owner, path);
}

bool Node::is_inside_tree() const {
	return call_engine<bool>(ARDY_ENGINE_METHOD(Node, is_inside_tree), _owner);
}

void Node::update_configuration_warnings() {
	call_engine<void>(ARDY_ENGINE_METHOD(Node, update_configuration_warnings), _owner);
}

void Node::set_process(bool enabled) {
	call_engine<void>(ARDY_ENGINE_METHOD(Node, set_process), _owner, enabled);
}

void Node::set_physics_process(bool enabled) {
	call_engine<void>(ARDY_ENGINE_METHOD(Node, set_physics_process), _owner, enabled);
}

void Node::add_child(Node *child, bool force_readable_name, InternalMode internal) {
	call_engine<void>(ARDY_ENGINE_METHOD(Node, add_child), _owner, child, force_readable_name, static_cast<int64_t>(internal));
}

void Node::remove_child(Node *child) {
	call_engine<void>(ARDY_ENGINE_METHOD(Node, remove_child), _owner, child);
}

void Node::queue_free() {
	call_engine<void>(ARDY_ENGINE_METHOD(Node, queue_free), _owner);
}

NodePath Node::get_path_to(const Node *node, bool use_unique_path) const {
	return call_engine<NodePath>(ARDY_ENGINE_METHOD(Node, get_path_to), _owner, node, use_unique_path);
}

Node *Node::get_parent() const {
	return call_engine<Node *>(ARDY_ENGINE_METHOD(Node, get_parent), _owner);
}

void Node3D::update_gizmos() {
	call_engine<void>(ARDY_ENGINE_METHOD(Node3D, update_gizmos), _owner);
}

Transform3D Node3D::get_global_transform() const {
	return call_engine<Transform3D>(ARDY_ENGINE_METHOD(Node3D, get_global_transform), _owner);
}

void Node3D::set_global_transform(const Transform3D &transform) {
	call_engine<void>(ARDY_ENGINE_METHOD(Node3D, set_global_transform), _owner, transform);
}

int32_t Skeleton3D::get_bone_parent(int32_t bone) const {
	return call_engine<int32_t>(ARDY_ENGINE_METHOD(Skeleton3D, get_bone_parent), _owner, bone);
}

Vector3 Skeleton3D::get_bone_pose_position(int32_t bone) const {
	return call_engine<Vector3>(ARDY_ENGINE_METHOD(Skeleton3D, get_bone_pose_position), _owner, bone);
}

void Skeleton3D::set_bone_pose_scale(int32_t bone, const Vector3 &scale) {
	call_engine<void>(ARDY_ENGINE_METHOD(Skeleton3D, set_bone_pose_scale), _owner, bone, scale);
}

uint64_t Skeleton3D::get_version() const {
	return call_engine<uint64_t>(ARDY_ENGINE_METHOD(Skeleton3D, get_version), _owner);
}

Skeleton3D *SkeletonModifier3D::get_skeleton() const {
	return call_engine<Skeleton3D *>(ARDY_ENGINE_METHOD(SkeletonModifier3D, get_skeleton), _owner);
}

void SkeletonModifier3D::set_influence(double influence) {
	call_engine<void>(ARDY_ENGINE_METHOD(SkeletonModifier3D, set_influence), _owner, influence);
}

double SkeletonModifier3D::get_influence() const {
	return call_engine<double>(ARDY_ENGINE_METHOD(SkeletonModifier3D, get_influence), _owner);
}

void CharacterBody3D::set_velocity(const Vector3 &velocity) {
	call_engine<void>(ARDY_ENGINE_METHOD(CharacterBody3D, set_velocity), _owner, velocity);
}

Vector3 CharacterBody3D::get_velocity() const {
	return call_engine<Vector3>(ARDY_ENGINE_METHOD(CharacterBody3D, get_velocity), _owner);
}

bool CharacterBody3D::move_and_slide() {
	return call_engine<bool>(ARDY_ENGINE_METHOD(CharacterBody3D, move_and_slide), _owner);
}

bool CharacterBody3D::is_on_floor() const {
	return call_engine<bool>(ARDY_ENGINE_METHOD(CharacterBody3D, is_on_floor), _owner);
}

Vector3 CharacterBody3D::get_gravity() const {
	return call_engine<Vector3>(ARDY_ENGINE_METHOD(PhysicsBody3D, get_gravity), _owner);
}

PackedVector3Array Curve3D::get_baked_points() const {
	return call_engine<PackedVector3Array>(ARDY_ENGINE_METHOD(Curve3D, get_baked_points), _owner);
}

Ref<Curve3D> Path3D::get_curve() const {
	return call_engine<Ref<Curve3D>>(ARDY_ENGINE_METHOD(Path3D, get_curve), _owner);
}

StringName BoneMap::get_skeleton_bone_name(const StringName &profile_bone) const {
	return call_engine<StringName>(ARDY_ENGINE_METHOD(BoneMap, get_skeleton_bone_name), _owner, profile_bone);
}

Object *object_from_instance_id(uint64_t id) {
	if (id == 0) {
		return nullptr;
	}
	GDExtensionObjectPtr object = gde.object_get_instance_from_id(id);
	return object != nullptr ? static_cast<Object *>(internal::wrapper_of(object)) : nullptr;
}

int32_t Skeleton3D::find_bone(const String &name) const {
	return call_engine<int32_t>(ARDY_ENGINE_METHOD(Skeleton3D, find_bone), _owner, name);
}

int32_t Skeleton3D::get_bone_count() const {
	return call_engine<int32_t>(ARDY_ENGINE_METHOD(Skeleton3D, get_bone_count), _owner);
}

String Skeleton3D::get_bone_name(int32_t bone) const {
	return call_engine<String>(ARDY_ENGINE_METHOD(Skeleton3D, get_bone_name), _owner, bone);
}

void Skeleton3D::set_bone_pose_rotation(int32_t bone, const Quaternion &rotation) {
	call_engine<void>(ARDY_ENGINE_METHOD(Skeleton3D, set_bone_pose_rotation), _owner, bone, rotation);
}

void Skeleton3D::set_bone_pose_position(int32_t bone, const Vector3 &position) {
	call_engine<void>(ARDY_ENGINE_METHOD(Skeleton3D, set_bone_pose_position), _owner, bone, position);
}

Quaternion Skeleton3D::get_bone_pose_rotation(int32_t bone) const {
	return call_engine<Quaternion>(ARDY_ENGINE_METHOD(Skeleton3D, get_bone_pose_rotation), _owner, bone);
}

Transform3D Skeleton3D::get_bone_rest(int32_t bone) const {
	return call_engine<Transform3D>(ARDY_ENGINE_METHOD(Skeleton3D, get_bone_rest), _owner, bone);
}

Ref<FileAccess> FileAccess::open(const String &path, ModeFlags mode) {
	return call_engine<Ref<FileAccess>>(ARDY_ENGINE_METHOD(FileAccess, open), nullptr, path, static_cast<int64_t>(mode));
}

Error FileAccess::get_open_error() {
	return static_cast<Error>(call_engine<int64_t>(ARDY_ENGINE_METHOD(FileAccess, get_open_error), nullptr));
}

uint64_t FileAccess::get_length() const {
	return call_engine<uint64_t>(ARDY_ENGINE_METHOD(FileAccess, get_length), _owner);
}

PackedByteArray FileAccess::get_buffer(int64_t length) const {
	return call_engine<PackedByteArray>(ARDY_ENGINE_METHOD(FileAccess, get_buffer), _owner, length);
}

bool FileAccess::store_string(const String &text) {
	return call_engine<bool>(ARDY_ENGINE_METHOD(FileAccess, store_string), _owner, text);
}

void Resource::emit_changed() {
	call_engine<void>(ARDY_ENGINE_METHOD(Resource, emit_changed), _owner);
}

int32_t Animation::add_track(TrackType type, int32_t at_position) {
	return static_cast<int32_t>(call_engine<int64_t>(ARDY_ENGINE_METHOD(Animation, add_track), _owner, static_cast<int64_t>(type), static_cast<int64_t>(at_position)));
}

void Animation::track_set_path(int32_t track, const NodePath &path) {
	call_engine<void>(ARDY_ENGINE_METHOD(Animation, track_set_path), _owner, static_cast<int64_t>(track), path);
}

int32_t Animation::rotation_track_insert_key(int32_t track, double time, const Quaternion &rotation) {
	return static_cast<int32_t>(call_engine<int64_t>(ARDY_ENGINE_METHOD(Animation, rotation_track_insert_key), _owner, static_cast<int64_t>(track), time, rotation));
}

int32_t Animation::position_track_insert_key(int32_t track, double time, const Vector3 &position) {
	return static_cast<int32_t>(call_engine<int64_t>(ARDY_ENGINE_METHOD(Animation, position_track_insert_key), _owner, static_cast<int64_t>(track), time, position));
}

void Animation::set_length(double seconds) {
	call_engine<void>(ARDY_ENGINE_METHOD(Animation, set_length), _owner, seconds);
}

void Animation::set_step(double seconds) {
	call_engine<void>(ARDY_ENGINE_METHOD(Animation, set_step), _owner, seconds);
}

void Animation::set_loop_mode(LoopMode mode) {
	call_engine<void>(ARDY_ENGINE_METHOD(Animation, set_loop_mode), _owner, static_cast<int64_t>(mode));
}

Error FileAccess::get_error() const {
	return static_cast<Error>(call_engine<int64_t>(ARDY_ENGINE_METHOD(FileAccess, get_error), _owner));
}

namespace {
Engine *engine_singleton = nullptr;
} // namespace

Engine *Engine::get_singleton() {
	if (engine_singleton == nullptr) {
		StringName name("Engine");
		engine_singleton = object_from_owner<Engine>(gde.global_get_singleton(name.native_ptr()));
	}
	return engine_singleton;
}

void internal::release_singleton_wrappers() {
	// The engine outlives this library: our wrapper must go while our code is loaded.
	if (engine_singleton != nullptr) {
		gde.object_free_instance_binding(engine_singleton->_owner, gde.token);
		engine_singleton = nullptr;
	}
}

bool Engine::is_editor_hint() const {
	return call_engine<bool>(ARDY_ENGINE_METHOD(Engine, is_editor_hint), _owner);
}

String error_string(Error error) {
	static const GDExtensionPtrUtilityFunction function = [] {
		StringName name("error_string");
		return gde.variant_get_ptr_utility_function(name.native_ptr(), engine_api::hash_utility_error_string);
	}();
	const int64_t code = error;
	const GDExtensionConstTypePtr args[1] = { &code };
	String result;
	function(result.native_ptr(), args, 1);
	return result;
}

} // namespace godot
