#pragma once
#include "builtins.hpp"

namespace godot {

class Object;

// An engine Variant (24 bytes, opaque). Conversions go through the engine's
// from-type and to-type constructors, so they behave exactly as in GDScript.
class Variant {
public:
	enum Type {
		NIL = GDEXTENSION_VARIANT_TYPE_NIL,
		BOOL = GDEXTENSION_VARIANT_TYPE_BOOL,
		INT = GDEXTENSION_VARIANT_TYPE_INT,
		FLOAT = GDEXTENSION_VARIANT_TYPE_FLOAT,
		STRING = GDEXTENSION_VARIANT_TYPE_STRING,
		VECTOR2 = GDEXTENSION_VARIANT_TYPE_VECTOR2,
		VECTOR3 = GDEXTENSION_VARIANT_TYPE_VECTOR3,
		TRANSFORM3D = GDEXTENSION_VARIANT_TYPE_TRANSFORM3D,
		QUATERNION = GDEXTENSION_VARIANT_TYPE_QUATERNION,
		BASIS = GDEXTENSION_VARIANT_TYPE_BASIS,
		COLOR = GDEXTENSION_VARIANT_TYPE_COLOR,
		STRING_NAME = GDEXTENSION_VARIANT_TYPE_STRING_NAME,
		NODE_PATH = GDEXTENSION_VARIANT_TYPE_NODE_PATH,
		OBJECT = GDEXTENSION_VARIANT_TYPE_OBJECT,
		DICTIONARY = GDEXTENSION_VARIANT_TYPE_DICTIONARY,
		ARRAY = GDEXTENSION_VARIANT_TYPE_ARRAY,
		PACKED_BYTE_ARRAY = GDEXTENSION_VARIANT_TYPE_PACKED_BYTE_ARRAY,
		PACKED_FLOAT32_ARRAY = GDEXTENSION_VARIANT_TYPE_PACKED_FLOAT32_ARRAY,
		PACKED_STRING_ARRAY = GDEXTENSION_VARIANT_TYPE_PACKED_STRING_ARRAY,
		PACKED_VECTOR3_ARRAY = GDEXTENSION_VARIANT_TYPE_PACKED_VECTOR3_ARRAY,
	};

	Variant();
	Variant(const Variant &other);
	Variant &operator=(const Variant &other);
	~Variant();

	Variant(bool value);
	Variant(int value) : Variant(static_cast<int64_t>(value)) {}
	Variant(int64_t value);
	Variant(float value) : Variant(static_cast<double>(value)) {}
	Variant(double value);
	Variant(const char *value) : Variant(String(value)) {}
	Variant(const String &value);
	Variant(const StringName &value);
	Variant(const NodePath &value);
	Variant(const Vector2 &value);
	Variant(const Vector3 &value);
	Variant(const Quaternion &value);
	Variant(const Basis &value);
	Variant(const Transform3D &value);
	Variant(const Color &value);
	Variant(const Array &value);
	Variant(const Dictionary &value);
	Variant(const PackedByteArray &value);
	Variant(const PackedFloat32Array &value);
	Variant(const PackedStringArray &value);
	Variant(const PackedVector3Array &value);
	Variant(const Object *value);

	Type get_type() const;
	bool is_nil() const { return get_type() == NIL; }

	// Converting reads. Call only when get_type() (or can_convert) allows it.
	operator bool() const;
	operator int64_t() const;
	operator int32_t() const { return static_cast<int32_t>(operator int64_t()); }
	operator double() const;
	operator float() const { return static_cast<float>(operator double()); }
	operator String() const;
	operator StringName() const;
	operator NodePath() const;
	operator Vector2() const;
	operator Vector3() const;
	operator Quaternion() const;
	operator Basis() const;
	operator Transform3D() const;
	operator Color() const;
	operator Array() const;
	operator Dictionary() const;
	operator PackedByteArray() const;
	operator PackedFloat32Array() const;
	operator PackedStringArray() const;
	operator PackedVector3Array() const;
	// The engine object held, or nullptr.
	GDExtensionObjectPtr object_ptr() const;

	// The value converted to `type` as the engine converts call arguments
	// (int -> float, String -> StringName, ...); false when not allowed.
	bool convert_to(Type type, Variant &r_result) const;

	void *native_ptr() { return opaque_; }
	const void *native_ptr() const { return opaque_; }

private:
	template <class T>
	void construct_from(GDExtensionVariantType type, const T &value);
	template <class T>
	T read_as(GDExtensionVariantType type) const;

	alignas(8) uint8_t opaque_[engine_api::size_Variant];
};

} // namespace godot
