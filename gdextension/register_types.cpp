// Entry point of the ARDY extension: loads the engine interface and registers
// our classes at the scene level (and their help pages in the editor).
#include "godot/class_db.hpp"
#include "godot/error_macros.hpp"
#include "nodes/model_cache.hpp"
#include "nodes/motion_goals.hpp"
#include "nodes/motion_generator.hpp"
#include "nodes/motion_pose_modifier.hpp"
#include "nodes/motion_timeline.hpp"

#include "doc_classes.gen.hpp"

#include <cstdio>

using namespace godot;

namespace {

void initialize(void *, GDExtensionInitializationLevel level) {
	if (level == GDEXTENSION_INITIALIZATION_SCENE) {
		ClassDB::register_class<ardy::MotionWaypoint>();
		ClassDB::register_class<ardy::MotionKeyframe>();
		ClassDB::register_class<ardy::MotionPrompt>();
		ClassDB::register_class<ardy::MotionPath>();
		ClassDB::register_class<ardy::MotionJointTarget>();
		ClassDB::register_class<ardy::MotionContact>();
		ClassDB::register_class<ardy::MotionTimeline>();
		ClassDB::register_class<ardy::MotionGenerator>();
		ClassDB::register_class<ardy::MotionPoseModifier>();
	}
	if (level == GDEXTENSION_INITIALIZATION_EDITOR) {
		for (const ardy_docs::DocClass &doc : ardy_docs::doc_classes) {
			ClassDB::load_editor_help(doc.xml, doc.size);
		}
	}
}

void deinitialize(void *, GDExtensionInitializationLevel level) {
	if (level == GDEXTENSION_INITIALIZATION_SCENE) {
		ardy::shut_down_model_loads();
		ClassDB::unregister_all();
		internal::release_singleton_wrappers();
	}
}

} // namespace

extern "C" {

__attribute__((visibility("default"))) GDExtensionBool ardy_library_init(GDExtensionInterfaceGetProcAddress get_proc_address, GDExtensionClassLibraryPtr library,
		GDExtensionInitialization *initialization) {
	if (const char *missing = internal::load_interface(get_proc_address, library)) {
		// No engine output exists without the interface: stderr is all we have.
		fprintf(stderr, "ARDY: this Godot lacks the interface function '%s'; Godot 4.5 or newer is required.\n", missing);
		return false;
	}
	initialization->initialize = &initialize;
	initialization->deinitialize = &deinitialize;
	initialization->userdata = nullptr;
	initialization->minimum_initialization_level = GDEXTENSION_INITIALIZATION_SCENE;
	return true;
}

}
