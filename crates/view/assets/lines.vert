#version 300 es
// Camera frusta: world-space line segments through the same pinhole (clip space with w = z).
precision highp float;
uniform mat3 u_cam_from_world;
uniform vec3 u_cam_t;
uniform vec4 u_intrinsics;
uniform vec2 u_size;
in vec3 a_position;
void main() {
    vec3 p = u_cam_from_world * a_position + u_cam_t;
    float near = 0.01, far = 1e4;
    float x = 2.0 * (u_intrinsics.x * p.x + u_intrinsics.z * p.z) / u_size.x - p.z;
    float y = p.z - 2.0 * (u_intrinsics.y * p.y + u_intrinsics.w * p.z) / u_size.y;
    float z = (p.z * (far + near) - 2.0 * far * near) / (far - near);
    gl_Position = vec4(x, y, z, p.z);
}
