#include "variant.hpp"

#include "engine_classes.hpp"

#include <new>

namespace godot {

using internal::gde;

Variant::Variant() {
	gde.variant_new_nil(opaque_);
}

Variant::Variant(const Variant &other) {
	gde.variant_new_copy(opaque_, other.opaque_);
}

Variant &Variant::operator=(const Variant &other) {
	if (this != &other) {
		gde.variant_destroy(opaque_);
		gde.variant_new_copy(opaque_, other.opaque_);
	}
	return *this;
}

Variant::~Variant() {
	gde.variant_destroy(opaque_);
}

template <class T>
void Variant::construct_from(GDExtensionVariantType type, const T &value) {
	gde.get_variant_from_type_constructor(type)(opaque_, const_cast<T *>(&value));
}

template <class T>
T Variant::read_as(GDExtensionVariantType type) const {
	// The engine writes into uninitialized storage; copy out, then destroy it.
	alignas(T) unsigned char storage[sizeof(T)];
	gde.get_variant_to_type_constructor(type)(storage, const_cast<uint8_t *>(opaque_));
	T *written = std::launder(reinterpret_cast<T *>(storage));
	T result = *written;
	written->~T();
	return result;
}

Variant::Variant(bool value) {
	const GDExtensionBool encoded = value ? 1 : 0;
	construct_from(GDEXTENSION_VARIANT_TYPE_BOOL, encoded);
}
Variant::Variant(int64_t value) { construct_from(GDEXTENSION_VARIANT_TYPE_INT, value); }
Variant::Variant(double value) { construct_from(GDEXTENSION_VARIANT_TYPE_FLOAT, value); }
Variant::Variant(const String &value) { gde.get_variant_from_type_constructor(GDEXTENSION_VARIANT_TYPE_STRING)(opaque_, const_cast<void *>(value.native_ptr())); }
Variant::Variant(const StringName &value) { gde.get_variant_from_type_constructor(GDEXTENSION_VARIANT_TYPE_STRING_NAME)(opaque_, const_cast<void *>(value.native_ptr())); }
Variant::Variant(const NodePath &value) { gde.get_variant_from_type_constructor(GDEXTENSION_VARIANT_TYPE_NODE_PATH)(opaque_, const_cast<void *>(value.native_ptr())); }
Variant::Variant(const Vector2 &value) { construct_from(GDEXTENSION_VARIANT_TYPE_VECTOR2, value); }
Variant::Variant(const Vector3 &value) { construct_from(GDEXTENSION_VARIANT_TYPE_VECTOR3, value); }
Variant::Variant(const Quaternion &value) { construct_from(GDEXTENSION_VARIANT_TYPE_QUATERNION, value); }
Variant::Variant(const Basis &value) { construct_from(GDEXTENSION_VARIANT_TYPE_BASIS, value); }
Variant::Variant(const Transform3D &value) { construct_from(GDEXTENSION_VARIANT_TYPE_TRANSFORM3D, value); }
Variant::Variant(const Color &value) { construct_from(GDEXTENSION_VARIANT_TYPE_COLOR, value); }
Variant::Variant(const Array &value) { gde.get_variant_from_type_constructor(GDEXTENSION_VARIANT_TYPE_ARRAY)(opaque_, const_cast<void *>(value.native_ptr())); }
Variant::Variant(const Dictionary &value) { gde.get_variant_from_type_constructor(GDEXTENSION_VARIANT_TYPE_DICTIONARY)(opaque_, const_cast<void *>(value.native_ptr())); }
Variant::Variant(const PackedByteArray &value) { gde.get_variant_from_type_constructor(GDEXTENSION_VARIANT_TYPE_PACKED_BYTE_ARRAY)(opaque_, const_cast<void *>(value.native_ptr())); }
Variant::Variant(const PackedFloat32Array &value) { gde.get_variant_from_type_constructor(GDEXTENSION_VARIANT_TYPE_PACKED_FLOAT32_ARRAY)(opaque_, const_cast<void *>(value.native_ptr())); }
Variant::Variant(const PackedStringArray &value) { gde.get_variant_from_type_constructor(GDEXTENSION_VARIANT_TYPE_PACKED_STRING_ARRAY)(opaque_, const_cast<void *>(value.native_ptr())); }
Variant::Variant(const PackedVector3Array &value) { gde.get_variant_from_type_constructor(GDEXTENSION_VARIANT_TYPE_PACKED_VECTOR3_ARRAY)(opaque_, const_cast<void *>(value.native_ptr())); }

Variant::Variant(const Object *value) {
	GDExtensionObjectPtr owner = value != nullptr ? value->_owner : nullptr;
	if (owner == nullptr) {
		gde.variant_new_nil(opaque_);
		return;
	}
	construct_from(GDEXTENSION_VARIANT_TYPE_OBJECT, owner);
}

Variant::Type Variant::get_type() const {
	return static_cast<Type>(gde.variant_get_type(opaque_));
}

Variant::operator bool() const { return read_as<GDExtensionBool>(GDEXTENSION_VARIANT_TYPE_BOOL) != 0; }
Variant::operator int64_t() const { return read_as<int64_t>(GDEXTENSION_VARIANT_TYPE_INT); }
Variant::operator double() const { return read_as<double>(GDEXTENSION_VARIANT_TYPE_FLOAT); }
Variant::operator String() const { return read_as<String>(GDEXTENSION_VARIANT_TYPE_STRING); }
Variant::operator StringName() const { return read_as<StringName>(GDEXTENSION_VARIANT_TYPE_STRING_NAME); }
Variant::operator NodePath() const { return read_as<NodePath>(GDEXTENSION_VARIANT_TYPE_NODE_PATH); }
Variant::operator Vector2() const { return read_as<Vector2>(GDEXTENSION_VARIANT_TYPE_VECTOR2); }
Variant::operator Vector3() const { return read_as<Vector3>(GDEXTENSION_VARIANT_TYPE_VECTOR3); }
Variant::operator Quaternion() const { return read_as<Quaternion>(GDEXTENSION_VARIANT_TYPE_QUATERNION); }
Variant::operator Basis() const { return read_as<Basis>(GDEXTENSION_VARIANT_TYPE_BASIS); }
Variant::operator Transform3D() const { return read_as<Transform3D>(GDEXTENSION_VARIANT_TYPE_TRANSFORM3D); }
Variant::operator Color() const { return read_as<Color>(GDEXTENSION_VARIANT_TYPE_COLOR); }
Variant::operator Array() const { return read_as<Array>(GDEXTENSION_VARIANT_TYPE_ARRAY); }
Variant::operator Dictionary() const { return read_as<Dictionary>(GDEXTENSION_VARIANT_TYPE_DICTIONARY); }
Variant::operator PackedByteArray() const { return read_as<PackedByteArray>(GDEXTENSION_VARIANT_TYPE_PACKED_BYTE_ARRAY); }
Variant::operator PackedFloat32Array() const { return read_as<PackedFloat32Array>(GDEXTENSION_VARIANT_TYPE_PACKED_FLOAT32_ARRAY); }
Variant::operator PackedStringArray() const { return read_as<PackedStringArray>(GDEXTENSION_VARIANT_TYPE_PACKED_STRING_ARRAY); }
Variant::operator PackedVector3Array() const { return read_as<PackedVector3Array>(GDEXTENSION_VARIANT_TYPE_PACKED_VECTOR3_ARRAY); }

GDExtensionObjectPtr Variant::object_ptr() const {
	if (get_type() != OBJECT) {
		return nullptr;
	}
	return read_as<GDExtensionObjectPtr>(GDEXTENSION_VARIANT_TYPE_OBJECT);
}

bool Variant::convert_to(Type type, Variant &r_result) const {
	if (get_type() == type) {
		r_result = *this;
		return true;
	}
	if (!gde.variant_can_convert_strict(static_cast<GDExtensionVariantType>(get_type()), static_cast<GDExtensionVariantType>(type))) {
		return false;
	}
	GDExtensionCallError error{};
	const GDExtensionConstVariantPtr args[1] = { opaque_ };
	gde.variant_destroy(r_result.opaque_);
	gde.variant_construct(static_cast<GDExtensionVariantType>(type), r_result.opaque_, args, 1, &error);
	if (error.error != GDEXTENSION_CALL_OK) {
		gde.variant_new_nil(r_result.opaque_);
		return false;
	}
	return true;
}

} // namespace godot
