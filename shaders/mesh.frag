#version 450 core
// Two-sided diffuse lighting from a light that moves with the camera; lines unlit. Fragments
// below u_clip_z0 (mm along the log) are cut away.
in vec3 v_pos;
in vec3 v_normal;
in vec3 v_color;

uniform vec3 u_light_dir;  // towards the light, log frame, unit
uniform int u_lit;
uniform float u_clip_z0;

out vec4 out_color;

void main() {
  if (v_pos.z < u_clip_z0) discard;
  if (u_lit == 0) {
    out_color = vec4(v_color, 1.0);
    return;
  }
  float d = abs(dot(normalize(v_normal), u_light_dir));
  out_color = vec4(v_color * (0.45 + 0.65 * d), 1.0);
}
