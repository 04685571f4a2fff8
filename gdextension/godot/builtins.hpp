#pragma once
// Builtin engine values. Math types are plain structs laid out as the engine
// lays them out (single precision); the rest are opaque handles created,
// copied and destroyed only through the engine's pointer constructors.
#include "engine_api.gen.hpp"
#include "interface.hpp"

#include <cstdint>
#include <string>

namespace godot {

struct Vector2 {
	float x = 0, y = 0;
};
struct Vector3 {
	float x = 0, y = 0, z = 0;
};
struct Quaternion {
	float x = 0, y = 0, z = 0, w = 1;
};
struct Basis {
	Vector3 rows[3] = { { 1, 0, 0 }, { 0, 1, 0 }, { 0, 0, 1 } };
};
struct Transform3D {
	Basis basis;
	Vector3 origin;
};
struct Color {
	float r = 0, g = 0, b = 0, a = 1;
};

static_assert(sizeof(Vector2) == engine_api::size_Vector2);
static_assert(sizeof(Vector3) == engine_api::size_Vector3);
static_assert(sizeof(Quaternion) == engine_api::size_Quaternion);
static_assert(sizeof(Basis) == engine_api::size_Basis);
static_assert(sizeof(Transform3D) == engine_api::size_Transform3D);
static_assert(sizeof(Color) == engine_api::size_Color);

namespace internal {
// Tag for constructors that leave the storage for the engine to fill.
struct Uninitialized {};

GDExtensionPtrConstructor builtin_constructor(GDExtensionVariantType type, int32_t index);
GDExtensionPtrDestructor builtin_destructor(GDExtensionVariantType type);
GDExtensionPtrBuiltInMethod builtin_method(GDExtensionVariantType type, const char *name, int64_t hash);

// Storage and lifetime shared by every opaque builtin type.
template <GDExtensionVariantType Type, std::size_t Size>
class OpaqueValue {
public:
	static constexpr GDExtensionVariantType variant_type = Type;

	OpaqueValue() { builtin_constructor(Type, 0)(opaque_, nullptr); }
	OpaqueValue(const OpaqueValue &other) { copy_from(other); }
	OpaqueValue &operator=(const OpaqueValue &other) {
		if (this != &other) {
			destroy();
			copy_from(other);
		}
		return *this;
	}
	~OpaqueValue() { destroy(); }

	void *native_ptr() { return opaque_; }
	const void *native_ptr() const { return opaque_; }

protected:
	explicit OpaqueValue(Uninitialized) {}

private:
	void copy_from(const OpaqueValue &other) {
		GDExtensionConstTypePtr args[1] = { other.opaque_ };
		builtin_constructor(Type, 1)(opaque_, args);
	}
	void destroy() {
		if (GDExtensionPtrDestructor destructor = builtin_destructor(Type)) {
			destructor(opaque_);
		}
	}
	alignas(8) uint8_t opaque_[Size];
};
} // namespace internal

#define ARDY_OPAQUE_TYPE(Name, TYPE)                                                                         \
	using Base = internal::OpaqueValue<GDEXTENSION_VARIANT_TYPE_##TYPE, engine_api::size_##Name>;            \
	friend class Variant;                                                                                  \
                                                                                                           \
public:                                                                                                    \
	Name() = default;                                                                                      \
	explicit Name(internal::Uninitialized tag) : Base(tag) {}

class StringName;
class NodePath;

class String : public internal::OpaqueValue<GDEXTENSION_VARIANT_TYPE_STRING, engine_api::size_String> {
	ARDY_OPAQUE_TYPE(String, STRING)
	String(const char *utf8);
	String(const std::string &utf8);
	String(const StringName &name);
	String(const NodePath &path);
	std::string utf8() const;
	int64_t length() const;
	bool is_empty() const { return length() == 0; }
	bool operator==(const String &other) const { return utf8() == other.utf8(); }
	bool operator!=(const String &other) const { return !(*this == other); }
};

class StringName : public internal::OpaqueValue<GDEXTENSION_VARIANT_TYPE_STRING_NAME, engine_api::size_StringName> {
	ARDY_OPAQUE_TYPE(StringName, STRING_NAME)
	StringName(const char *utf8);
	StringName(const String &text);
	std::string utf8() const { return String(*this).utf8(); }
};

class NodePath : public internal::OpaqueValue<GDEXTENSION_VARIANT_TYPE_NODE_PATH, engine_api::size_NodePath> {
	ARDY_OPAQUE_TYPE(NodePath, NODE_PATH)
	NodePath(const char *utf8) : NodePath(String(utf8)) {}
	NodePath(const String &text);
	bool is_empty() const { return String(*this).is_empty(); }
};

class Variant;

class Array : public internal::OpaqueValue<GDEXTENSION_VARIANT_TYPE_ARRAY, engine_api::size_Array> {
	ARDY_OPAQUE_TYPE(Array, ARRAY)
	int64_t size() const;
	Variant operator[](int64_t index) const;
	void push_back(const Variant &value);
};

class Dictionary : public internal::OpaqueValue<GDEXTENSION_VARIANT_TYPE_DICTIONARY, engine_api::size_Dictionary> {
	ARDY_OPAQUE_TYPE(Dictionary, DICTIONARY)
	int64_t size() const;
	Array keys() const;
	// The value stored under `key`; a nil Variant when absent.
	Variant get(const Variant &key) const;
	void set(const Variant &key, const Variant &value);
};

// Packed arrays expose their contiguous storage, as the engine does.
template <GDExtensionVariantType Type, class Element>
class PackedArray : public internal::OpaqueValue<Type, 16> {
	using Base = internal::OpaqueValue<Type, 16>;

public:
	using Base::Base;
	int64_t size() const {
		int64_t result = 0;
		static const GDExtensionPtrBuiltInMethod method = internal::builtin_method(Type, "size", engine_api::hash_PackedByteArray_size);
		method(const_cast<void *>(this->native_ptr()), nullptr, &result, 0);
		return result;
	}
	bool is_empty() const { return size() == 0; }
	void resize(int64_t count) {
		int64_t result = 0;
		const GDExtensionConstTypePtr args[1] = { &count };
		static const GDExtensionPtrBuiltInMethod method = internal::builtin_method(Type, "resize", engine_api::hash_PackedByteArray_resize);
		method(this->native_ptr(), args, &result, 1);
	}
	Element *ptrw();
	const Element *ptr() const { return const_cast<PackedArray *>(this)->ptrw(); }
	Element &operator[](int64_t index) { return ptrw()[index]; }
	const Element &operator[](int64_t index) const { return ptr()[index]; }
	void push_back(const Element &value) {
		const int64_t n = size();
		resize(n + 1);
		ptrw()[n] = value;
	}
};

using PackedByteArray = PackedArray<GDEXTENSION_VARIANT_TYPE_PACKED_BYTE_ARRAY, uint8_t>;
using PackedFloat32Array = PackedArray<GDEXTENSION_VARIANT_TYPE_PACKED_FLOAT32_ARRAY, float>;
using PackedVector3Array = PackedArray<GDEXTENSION_VARIANT_TYPE_PACKED_VECTOR3_ARRAY, Vector3>;
using PackedStringArray = PackedArray<GDEXTENSION_VARIANT_TYPE_PACKED_STRING_ARRAY, String>;

template <>
uint8_t *PackedByteArray::ptrw();
template <>
float *PackedFloat32Array::ptrw();
template <>
Vector3 *PackedVector3Array::ptrw();
template <>
String *PackedStringArray::ptrw();

#undef ARDY_OPAQUE_TYPE

} // namespace godot
