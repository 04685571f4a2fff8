#pragma once
// The one place engine math types and the runtime's GLM types meet.
#include "godot/builtins.hpp"

#include <cmath>

#include <glm/gtc/quaternion.hpp>
#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>

namespace ardy {

inline glm::vec3 to_glm(const godot::Vector3 &v) {
	return { v.x, v.y, v.z };
}

inline godot::Vector3 to_godot(const glm::vec3 &v) {
	return { v.x, v.y, v.z };
}

inline glm::quat to_glm(const godot::Quaternion &q) {
	return glm::quat(q.w, q.x, q.y, q.z);
}

inline godot::Quaternion to_godot(const glm::quat &q) {
	return { q.x, q.y, q.z, q.w };
}

// Godot stores a Basis by rows; GLM matrices are column-major.
inline glm::mat3 to_glm(const godot::Basis &basis) {
	glm::mat3 m;
	for (int row = 0; row < 3; ++row) {
		m[0][row] = basis.rows[row].x;
		m[1][row] = basis.rows[row].y;
		m[2][row] = basis.rows[row].z;
	}
	return m;
}

inline godot::Basis to_godot(const glm::mat3 &m) {
	godot::Basis basis;
	for (int row = 0; row < 3; ++row) {
		basis.rows[row] = { m[0][row], m[1][row], m[2][row] };
	}
	return basis;
}

// A rigid transform with uniform scale, as the node reasons about world space.
struct Frame {
	glm::mat3 basis{ 1.0f };  // may hold scale
	glm::vec3 origin{ 0.0f };

	glm::vec3 apply(const glm::vec3 &point) const { return basis * point + origin; }
	glm::vec3 apply_inverse(const glm::vec3 &point) const { return glm::inverse(basis) * (point - origin); }
	// The rotation part (columns normalized).
	glm::quat rotation() const {
		glm::mat3 m = basis;
		for (int c = 0; c < 3; ++c) {
			m[c] = glm::normalize(m[c]);
		}
		return glm::normalize(glm::quat_cast(m));
	}
	float scale() const { return glm::length(basis[1]); }
	// Heading about +Y (0 faces +Z, turning +Z towards +X).
	float yaw() const { return std::atan2(basis[2].x, basis[2].z); }
};

inline Frame to_frame(const godot::Transform3D &transform) {
	return { to_glm(transform.basis), to_glm(transform.origin) };
}

inline godot::Transform3D to_godot(const Frame &frame) {
	return { to_godot(frame.basis), to_godot(frame.origin) };
}

} // namespace ardy
