#include "builtins.hpp"

#include "variant.hpp"

namespace godot {

using internal::gde;

namespace internal {

GDExtensionPtrConstructor builtin_constructor(GDExtensionVariantType type, int32_t index) {
	return gde.variant_get_ptr_constructor(type, index);
}

GDExtensionPtrDestructor builtin_destructor(GDExtensionVariantType type) {
	return gde.variant_get_ptr_destructor(type);
}

GDExtensionPtrBuiltInMethod builtin_method(GDExtensionVariantType type, const char *name, int64_t hash) {
	StringName method_name(name);
	return gde.variant_get_ptr_builtin_method(type, method_name.native_ptr(), hash);
}

} // namespace internal

namespace {
// Constructs `target` (uninitialized storage) from one argument of another type.
void construct_converted(GDExtensionVariantType type, int32_t index, void *target, const void *source) {
	GDExtensionConstTypePtr args[1] = { source };
	internal::builtin_constructor(type, index)(target, args);
}
} // namespace

String::String(const char *utf8) : Base(internal::Uninitialized{}) {
	const std::string text = utf8 != nullptr ? utf8 : "";
	gde.string_new_with_utf8_chars_and_len2(native_ptr(), text.data(), static_cast<GDExtensionInt>(text.size()));
}

String::String(const std::string &utf8) : Base(internal::Uninitialized{}) {
	gde.string_new_with_utf8_chars_and_len2(native_ptr(), utf8.data(), static_cast<GDExtensionInt>(utf8.size()));
}

String::String(const StringName &name) : Base(internal::Uninitialized{}) {
	construct_converted(GDEXTENSION_VARIANT_TYPE_STRING, 2, native_ptr(), name.native_ptr());
}

String::String(const NodePath &path) : Base(internal::Uninitialized{}) {
	construct_converted(GDEXTENSION_VARIANT_TYPE_STRING, 3, native_ptr(), path.native_ptr());
}

std::string String::utf8() const {
	const GDExtensionInt length = gde.string_to_utf8_chars(native_ptr(), nullptr, 0);
	std::string result(static_cast<std::size_t>(length), '\0');
	if (length > 0) {
		gde.string_to_utf8_chars(native_ptr(), result.data(), length);
	}
	return result;
}

int64_t String::length() const {
	int64_t result = 0;
	static const GDExtensionPtrBuiltInMethod method = internal::builtin_method(GDEXTENSION_VARIANT_TYPE_STRING, "length", engine_api::hash_String_length);
	method(const_cast<void *>(native_ptr()), nullptr, &result, 0);
	return result;
}

StringName::StringName(const char *utf8) : Base(internal::Uninitialized{}) {
	gde.string_name_new_with_utf8_chars(native_ptr(), utf8 != nullptr ? utf8 : "");
}

StringName::StringName(const String &text) : Base(internal::Uninitialized{}) {
	construct_converted(GDEXTENSION_VARIANT_TYPE_STRING_NAME, 2, native_ptr(), text.native_ptr());
}

NodePath::NodePath(const String &text) : Base(internal::Uninitialized{}) {
	construct_converted(GDEXTENSION_VARIANT_TYPE_NODE_PATH, 2, native_ptr(), text.native_ptr());
}

int64_t Array::size() const {
	int64_t result = 0;
	static const GDExtensionPtrBuiltInMethod method = internal::builtin_method(GDEXTENSION_VARIANT_TYPE_ARRAY, "size", engine_api::hash_Array_size);
	method(const_cast<void *>(native_ptr()), nullptr, &result, 0);
	return result;
}

Variant Array::operator[](int64_t index) const {
	return *static_cast<const Variant *>(gde.array_operator_index_const(native_ptr(), index));
}

void Array::push_back(const Variant &value) {
	const GDExtensionConstTypePtr args[1] = { value.native_ptr() };
	static const GDExtensionPtrBuiltInMethod method = internal::builtin_method(GDEXTENSION_VARIANT_TYPE_ARRAY, "push_back", engine_api::hash_Array_push_back);
	method(native_ptr(), args, nullptr, 1);
}

int64_t Dictionary::size() const {
	int64_t result = 0;
	static const GDExtensionPtrBuiltInMethod method = internal::builtin_method(GDEXTENSION_VARIANT_TYPE_DICTIONARY, "size", engine_api::hash_Dictionary_size);
	method(const_cast<void *>(native_ptr()), nullptr, &result, 0);
	return result;
}

Array Dictionary::keys() const {
	Array result;
	static const GDExtensionPtrBuiltInMethod method = internal::builtin_method(GDEXTENSION_VARIANT_TYPE_DICTIONARY, "keys", engine_api::hash_Dictionary_keys);
	method(const_cast<void *>(native_ptr()), nullptr, result.native_ptr(), 0);
	return result;
}

Variant Dictionary::get(const Variant &key) const {
	const void *value = gde.dictionary_operator_index_const(native_ptr(), key.native_ptr());
	return value != nullptr ? *static_cast<const Variant *>(value) : Variant();
}

void Dictionary::set(const Variant &key, const Variant &value) {
	*static_cast<Variant *>(gde.dictionary_operator_index(native_ptr(), key.native_ptr())) = value;
}

template <>
uint8_t *PackedByteArray::ptrw() {
	return size() > 0 ? gde.packed_byte_array_operator_index(native_ptr(), 0) : nullptr;
}

template <>
float *PackedFloat32Array::ptrw() {
	return size() > 0 ? gde.packed_float32_array_operator_index(native_ptr(), 0) : nullptr;
}

template <>
Vector3 *PackedVector3Array::ptrw() {
	return size() > 0 ? static_cast<Vector3 *>(gde.packed_vector3_array_operator_index(native_ptr(), 0)) : nullptr;
}

template <>
String *PackedStringArray::ptrw() {
	return size() > 0 ? static_cast<String *>(gde.packed_string_array_operator_index(native_ptr(), 0)) : nullptr;
}

} // namespace godot
