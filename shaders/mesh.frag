#version 450 core
// Two-sided diffuse lighting from a light that moves with the camera; lines unlit. Fragments
// below u_clip_z0 (mm along the log) are cut away. Translucent meshes (MeshStyle, gl_layers.h):
// opacity u_alpha where the surface faces the eye, rising by u_rim towards the silhouette, and
// an optional highlight (u_specular).
in vec3 v_pos;
in vec3 v_normal;
in vec3 v_color;

uniform vec3 u_light_dir;  // towards the light, log frame, unit
uniform int u_lit;
uniform float u_clip_z0;
uniform vec3 u_eye;        // camera position, log frame (mm)
uniform float u_alpha;     // 1: opaque
uniform float u_rim;       // 0: no silhouette term
uniform float u_specular;  // 0: no highlight

out vec4 out_color;

void main() {
  if (v_pos.z < u_clip_z0) discard;
  if (u_lit == 0) {
    out_color = vec4(v_color, 1.0);
    return;
  }
  vec3 n = normalize(v_normal);
  float d = abs(dot(n, u_light_dir));
  vec3 color = v_color * (0.45 + 0.65 * d);
  if (u_alpha >= 1.0 && u_rim <= 0.0 && u_specular <= 0.0) {
    out_color = vec4(color, 1.0);
    return;
  }
  vec3 view = normalize(u_eye - v_pos);
  float facing = abs(dot(n, view));
  if (u_specular > 0.0) {
    vec3 h = normalize(u_light_dir + view);
    color += vec3(u_specular * pow(abs(dot(n, h)), 40.0));
  }
  float edge = 1.0 - facing;
  out_color = vec4(min(color, vec3(1.0)), clamp(u_alpha + u_rim * edge * edge, 0.0, 1.0));
}
