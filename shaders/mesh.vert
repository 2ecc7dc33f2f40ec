#version 450 core
// The viewer's plain meshes (knot tubes, outlines): positions and normals in the log frame (mm),
// a colour per vertex.
layout(location = 0) in vec3 a_pos;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec3 a_color;

uniform mat4 u_view_proj;

out vec3 v_pos;
out vec3 v_normal;
out vec3 v_color;

void main() {
  v_pos = a_pos;
  v_normal = a_normal;
  v_color = a_color;
  gl_Position = u_view_proj * vec4(a_pos, 1.0);
}
