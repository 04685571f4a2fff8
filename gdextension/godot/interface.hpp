#pragma once
// The engine's function table, fetched by name once at load time. This is the
// only global mutable state of the extension (design.md section 10).
#include <gdextension_interface.h>

namespace godot::internal {

// X(member, InterfaceTypeSuffix, "engine name")
#define ARDY_GDE_FUNCTIONS(X)                                                                    \
	X(get_godot_version2, GetGodotVersion2, "get_godot_version2")                                \
	X(mem_alloc, MemAlloc, "mem_alloc")                                                          \
	X(mem_free, MemFree, "mem_free")                                                             \
	X(print_error, PrintError, "print_error")                                                    \
	X(print_warning, PrintWarning, "print_warning")                                              \
	X(variant_new_copy, VariantNewCopy, "variant_new_copy")                                      \
	X(variant_new_nil, VariantNewNil, "variant_new_nil")                                         \
	X(variant_destroy, VariantDestroy, "variant_destroy")                                        \
	X(variant_get_type, VariantGetType, "variant_get_type")                                      \
	X(variant_can_convert_strict, VariantCanConvertStrict, "variant_can_convert_strict")         \
	X(variant_construct, VariantConstruct, "variant_construct")                                  \
	X(variant_get_ptr_constructor, VariantGetPtrConstructor, "variant_get_ptr_constructor")      \
	X(variant_get_ptr_destructor, VariantGetPtrDestructor, "variant_get_ptr_destructor")         \
	X(variant_get_ptr_builtin_method, VariantGetPtrBuiltinMethod, "variant_get_ptr_builtin_method") \
	X(variant_get_ptr_utility_function, VariantGetPtrUtilityFunction, "variant_get_ptr_utility_function") \
	X(get_variant_from_type_constructor, GetVariantFromTypeConstructor, "get_variant_from_type_constructor") \
	X(get_variant_to_type_constructor, GetVariantToTypeConstructor, "get_variant_to_type_constructor") \
	X(string_new_with_utf8_chars_and_len2, StringNewWithUtf8CharsAndLen2, "string_new_with_utf8_chars_and_len2") \
	X(string_to_utf8_chars, StringToUtf8Chars, "string_to_utf8_chars")                           \
	X(string_name_new_with_utf8_chars, StringNameNewWithUtf8Chars, "string_name_new_with_utf8_chars") \
	X(packed_byte_array_operator_index, PackedByteArrayOperatorIndex, "packed_byte_array_operator_index") \
	X(packed_float32_array_operator_index, PackedFloat32ArrayOperatorIndex, "packed_float32_array_operator_index") \
	X(packed_string_array_operator_index, PackedStringArrayOperatorIndex, "packed_string_array_operator_index") \
	X(packed_vector3_array_operator_index, PackedVector3ArrayOperatorIndex, "packed_vector3_array_operator_index") \
	X(array_operator_index, ArrayOperatorIndex, "array_operator_index")                          \
	X(array_operator_index_const, ArrayOperatorIndexConst, "array_operator_index_const")         \
	X(dictionary_operator_index, DictionaryOperatorIndex, "dictionary_operator_index")           \
	X(dictionary_operator_index_const, DictionaryOperatorIndexConst, "dictionary_operator_index_const") \
	X(object_method_bind_call, ObjectMethodBindCall, "object_method_bind_call")                  \
	X(object_method_bind_ptrcall, ObjectMethodBindPtrcall, "object_method_bind_ptrcall")         \
	X(object_destroy, ObjectDestroy, "object_destroy")                                           \
	X(object_get_instance_from_id, ObjectGetInstanceFromId, "object_get_instance_from_id")      \
	X(global_get_singleton, GlobalGetSingleton, "global_get_singleton")                          \
	X(object_get_instance_binding, ObjectGetInstanceBinding, "object_get_instance_binding")      \
	X(object_free_instance_binding, ObjectFreeInstanceBinding, "object_free_instance_binding")   \
	X(object_set_instance_binding, ObjectSetInstanceBinding, "object_set_instance_binding")      \
	X(object_set_instance, ObjectSetInstance, "object_set_instance")                             \
	X(object_cast_to, ObjectCastTo, "object_cast_to")                                            \
	X(ref_get_object, RefGetObject, "ref_get_object")                                            \
	X(ref_set_object, RefSetObject, "ref_set_object")                                            \
	X(classdb_construct_object2, ClassdbConstructObject2, "classdb_construct_object2")          \
	X(classdb_get_method_bind, ClassdbGetMethodBind, "classdb_get_method_bind")                  \
	X(classdb_get_class_tag, ClassdbGetClassTag, "classdb_get_class_tag")                        \
	X(classdb_register_extension_class5, ClassdbRegisterExtensionClass5, "classdb_register_extension_class5") \
	X(classdb_register_extension_class_method, ClassdbRegisterExtensionClassMethod, "classdb_register_extension_class_method") \
	X(classdb_register_extension_class_property, ClassdbRegisterExtensionClassProperty, "classdb_register_extension_class_property") \
	X(classdb_register_extension_class_property_group, ClassdbRegisterExtensionClassPropertyGroup, "classdb_register_extension_class_property_group") \
	X(classdb_register_extension_class_signal, ClassdbRegisterExtensionClassSignal, "classdb_register_extension_class_signal") \
	X(classdb_unregister_extension_class, ClassdbUnregisterExtensionClass, "classdb_unregister_extension_class")

// Present only in editor builds of the engine, so not required.
#define ARDY_GDE_OPTIONAL_FUNCTIONS(X) \
	X(editor_help_load_xml_from_utf8_chars_and_len, EditorHelpLoadXmlFromUtf8CharsAndLen, "editor_help_load_xml_from_utf8_chars_and_len")

// The editor-help typedef is spelled with "Extensions" in the engine header.
using GDExtensionInterfaceEditorHelpLoadXmlFromUtf8CharsAndLen = GDExtensionsInterfaceEditorHelpLoadXmlFromUtf8CharsAndLen;

struct Interface {
#define ARDY_GDE_MEMBER(member, type, name) GDExtensionInterface##type member = nullptr;
	ARDY_GDE_FUNCTIONS(ARDY_GDE_MEMBER)
	ARDY_GDE_OPTIONAL_FUNCTIONS(ARDY_GDE_MEMBER)
#undef ARDY_GDE_MEMBER
	GDExtensionClassLibraryPtr library = nullptr;
	// Identifies our instance bindings on engine objects.
	void *token = nullptr;
};

extern Interface gde;

// Fills `gde`; returns the name of the first missing function, or nullptr.
const char *load_interface(GDExtensionInterfaceGetProcAddress get_proc_address, GDExtensionClassLibraryPtr library);

} // namespace godot::internal
