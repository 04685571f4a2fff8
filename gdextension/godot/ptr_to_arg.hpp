#pragma once
// How each C++ type crosses the interface: as a ptrcall argument or return
// (PtrToArg), as a Variant (VariantCaster), and how it is described to the
// engine when a method is registered (TypeInfo).
#include "ref.hpp"

#include <type_traits>

namespace godot {

// ---- ptrcall encoding -------------------------------------------------------

template <class T, class Enable = void>
struct PtrToArg {
	// Builtins travel as themselves.
	using Encoded = T;
	static Encoded encode(const T &value) { return value; }
	static T decode(const Encoded &value) { return value; }
	static T decode_return(Encoded &value) { return value; }
};

template <>
struct PtrToArg<bool> {
	using Encoded = bool;
	static Encoded encode(bool value) { return value; }
	static bool decode(Encoded value) { return value; }
	static bool decode_return(Encoded &value) { return value; }
};

// Integers travel as int64, floats as double.
template <class T>
struct PtrToArg<T, std::enable_if_t<std::is_integral_v<T> && !std::is_same_v<T, bool>>> {
	using Encoded = int64_t;
	static Encoded encode(T value) { return static_cast<int64_t>(value); }
	static T decode(Encoded value) { return static_cast<T>(value); }
	static T decode_return(Encoded &value) { return static_cast<T>(value); }
};

template <class T>
struct PtrToArg<T, std::enable_if_t<std::is_floating_point_v<T>>> {
	using Encoded = double;
	static Encoded encode(T value) { return static_cast<double>(value); }
	static T decode(Encoded value) { return static_cast<T>(value); }
	static T decode_return(Encoded &value) { return static_cast<T>(value); }
};

template <class T>
struct PtrToArg<T *, std::enable_if_t<std::is_base_of_v<Object, T>>> {
	using Encoded = GDExtensionObjectPtr;
	static Encoded encode(const T *value) { return value != nullptr ? value->_owner : nullptr; }
	static T *decode(Encoded value) { return object_from_owner<T>(value); }
	static T *decode_return(Encoded &value) { return object_from_owner<T>(value); }
};

template <class T>
struct PtrToArg<Ref<T>> {
	using Encoded = GDExtensionObjectPtr;
	static Encoded encode(const Ref<T> &value) { return value.is_valid() ? value->_owner : nullptr; }
	static Ref<T> decode(Encoded value) { return Ref<T>(object_from_owner<T>(value)); }
	// The engine assigned into a null Ref: that reference is now ours.
	static Ref<T> decode_return(Encoded &value) { return Ref<T>::adopt(value); }
};

// Writes a return value into the engine's (initialized) return storage.
template <class T>
void write_ptr_return(const T &value, void *r_ret) {
	*static_cast<typename PtrToArg<T>::Encoded *>(r_ret) = PtrToArg<T>::encode(value);
}
template <class T>
void write_ptr_return(const Ref<T> &value, void *r_ret) {
	internal::gde.ref_set_object(r_ret, value.is_valid() ? value->_owner : nullptr);
}

// ---- registration metadata --------------------------------------------------

template <class T, class Enable = void>
struct TypeInfo;

#define ARDY_TYPE_INFO(m_type, m_variant, m_meta)                                          \
	template <>                                                                            \
	struct TypeInfo<m_type> {                                                              \
		static constexpr Variant::Type type = Variant::m_variant;                          \
		static constexpr GDExtensionClassMethodArgumentMetadata metadata = m_meta;         \
		static const char *class_name() { return ""; }                                     \
	};

ARDY_TYPE_INFO(bool, BOOL, GDEXTENSION_METHOD_ARGUMENT_METADATA_NONE)
ARDY_TYPE_INFO(int32_t, INT, GDEXTENSION_METHOD_ARGUMENT_METADATA_INT_IS_INT32)
ARDY_TYPE_INFO(int64_t, INT, GDEXTENSION_METHOD_ARGUMENT_METADATA_INT_IS_INT64)
ARDY_TYPE_INFO(float, FLOAT, GDEXTENSION_METHOD_ARGUMENT_METADATA_REAL_IS_FLOAT)
ARDY_TYPE_INFO(double, FLOAT, GDEXTENSION_METHOD_ARGUMENT_METADATA_REAL_IS_DOUBLE)
ARDY_TYPE_INFO(String, STRING, GDEXTENSION_METHOD_ARGUMENT_METADATA_NONE)
ARDY_TYPE_INFO(StringName, STRING_NAME, GDEXTENSION_METHOD_ARGUMENT_METADATA_NONE)
ARDY_TYPE_INFO(NodePath, NODE_PATH, GDEXTENSION_METHOD_ARGUMENT_METADATA_NONE)
ARDY_TYPE_INFO(Vector2, VECTOR2, GDEXTENSION_METHOD_ARGUMENT_METADATA_NONE)
ARDY_TYPE_INFO(Vector3, VECTOR3, GDEXTENSION_METHOD_ARGUMENT_METADATA_NONE)
ARDY_TYPE_INFO(Quaternion, QUATERNION, GDEXTENSION_METHOD_ARGUMENT_METADATA_NONE)
ARDY_TYPE_INFO(Basis, BASIS, GDEXTENSION_METHOD_ARGUMENT_METADATA_NONE)
ARDY_TYPE_INFO(Transform3D, TRANSFORM3D, GDEXTENSION_METHOD_ARGUMENT_METADATA_NONE)
ARDY_TYPE_INFO(Color, COLOR, GDEXTENSION_METHOD_ARGUMENT_METADATA_NONE)
ARDY_TYPE_INFO(Array, ARRAY, GDEXTENSION_METHOD_ARGUMENT_METADATA_NONE)
ARDY_TYPE_INFO(Dictionary, DICTIONARY, GDEXTENSION_METHOD_ARGUMENT_METADATA_NONE)
ARDY_TYPE_INFO(PackedByteArray, PACKED_BYTE_ARRAY, GDEXTENSION_METHOD_ARGUMENT_METADATA_NONE)
ARDY_TYPE_INFO(PackedFloat32Array, PACKED_FLOAT32_ARRAY, GDEXTENSION_METHOD_ARGUMENT_METADATA_NONE)
ARDY_TYPE_INFO(PackedStringArray, PACKED_STRING_ARRAY, GDEXTENSION_METHOD_ARGUMENT_METADATA_NONE)
ARDY_TYPE_INFO(PackedVector3Array, PACKED_VECTOR3_ARRAY, GDEXTENSION_METHOD_ARGUMENT_METADATA_NONE)
#undef ARDY_TYPE_INFO

// A Variant parameter accepts anything.
template <>
struct TypeInfo<Variant> {
	static constexpr Variant::Type type = Variant::NIL;
	static constexpr GDExtensionClassMethodArgumentMetadata metadata = GDEXTENSION_METHOD_ARGUMENT_METADATA_NONE;
	static const char *class_name() { return ""; }
};

template <class T>
struct TypeInfo<T *, std::enable_if_t<std::is_base_of_v<Object, T>>> {
	static constexpr Variant::Type type = Variant::OBJECT;
	static constexpr GDExtensionClassMethodArgumentMetadata metadata = GDEXTENSION_METHOD_ARGUMENT_METADATA_NONE;
	static const char *class_name() { return T::get_class_static(); }
};

template <class T>
struct TypeInfo<Ref<T>> {
	static constexpr Variant::Type type = Variant::OBJECT;
	static constexpr GDExtensionClassMethodArgumentMetadata metadata = GDEXTENSION_METHOD_ARGUMENT_METADATA_NONE;
	static const char *class_name() { return T::get_class_static(); }
};

// ---- Variant conversion -----------------------------------------------------

template <class T, class Enable = void>
struct VariantCaster {
	static T from(const Variant &value) { return static_cast<T>(value); }
	static Variant to(const T &value) { return Variant(value); }
};

template <>
struct VariantCaster<Variant> {
	static Variant from(const Variant &value) { return value; }
	static Variant to(const Variant &value) { return value; }
};

template <class T>
struct VariantCaster<T *, std::enable_if_t<std::is_base_of_v<Object, T>>> {
	static T *from(const Variant &value) { return object_from_owner<T>(value.object_ptr()); }
	static Variant to(const T *value) { return Variant(static_cast<const Object *>(value)); }
};

template <class T>
struct VariantCaster<Ref<T>> {
	static Ref<T> from(const Variant &value) { return Ref<T>(object_from_owner<T>(value.object_ptr())); }
	static Variant to(const Ref<T> &value) { return Variant(static_cast<const Object *>(value.ptr())); }
};

template <class T>
using Bare = std::remove_cv_t<std::remove_reference_t<T>>;

} // namespace godot
