// Vertex stage of the knotted-wood renderer: positions and normals in the log frame (mm), passed
// on unchanged so the fragment stage evaluates the wood field at the exact 3D point.
layout(location = 0) in vec3 a_pos;
layout(location = 1) in vec3 a_normal;

uniform mat4 u_view_proj;

out vec3 v_pos;
out vec3 v_normal;

void main() {
  v_pos = a_pos;
  v_normal = a_normal;
  gl_Position = u_view_proj * vec4(a_pos, 1.0);
}
