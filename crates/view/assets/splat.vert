#version 300 es
// One instanced quad per Gaussian: the EWA projection of splatseg-render (gsplat's math).
// Σ_c = W Σ Wᵀ, Jacobian at the clamped (tx, ty), Σ_2d = J Σ_c Jᵀ + 0.3·I, conic = Σ_2d⁻¹,
// centre (fx·x/z + cx, fy·y/z + cy) in px with the pixel-corner origin (OpenCV axes).
precision highp float;
precision highp int;
precision highp usampler2D;

uniform usampler2D u_data;   // 3 RGBA32UI texels per Gaussian, 1024 Gaussians per row
uniform usampler2D u_slots;  // per Gaussian: its object slot (bit 31: in the Gaussian selection), 1024 per row
uniform sampler2D u_state;   // per object slot: rgb = colour override, a = flags
uniform mat3 u_cam_from_world;
uniform vec3 u_cam_t;
uniform vec4 u_intrinsics;   // fx, fy, cx, cy (px)
uniform vec2 u_size;         // width, height (px)
uniform bool u_palette;      // show objects in their palette colours

in vec2 a_corner;            // quad corner in [-1, 1]²
in uint a_index;             // Gaussian index (instanced, back to front)

out vec2 v_offset;           // pixel minus centre, px
flat out vec3 v_conic;
flat out vec4 v_colour;      // rgb, opacity
flat out uint v_slot;
flat out uint v_index;
flat out uint v_flags;

const uint HIDDEN = 1u;
const uint SELECTED = 2u;
const uint RECOLOURED = 4u;
const uint HIGHLIGHT = 8u;
const uint PICKED = 16u;     // the Gaussian is in the edit's Gaussian selection

void cull() {
    gl_Position = vec4(0.0, 0.0, 2.0, 1.0);
}

void main() {
    ivec2 base = ivec2(int(a_index % 1024u) * 3, int(a_index / 1024u));
    uvec4 t0 = texelFetch(u_data, base, 0);
    uvec4 t1 = texelFetch(u_data, base + ivec2(1, 0), 0);
    uvec4 t2 = texelFetch(u_data, base + ivec2(2, 0), 0);
    uint slotBits = texelFetch(u_slots, ivec2(int(a_index % 1024u), int(a_index / 1024u)), 0).r;
    uint slot = slotBits & 0x7fffffffu;
    vec4 state = texelFetch(u_state, ivec2(int(slot % 1024u), int(slot / 1024u)), 0);
    uint flags = uint(state.a * 255.0 + 0.5) | ((slotBits >> 31) != 0u ? PICKED : 0u);
    if ((flags & HIDDEN) != 0u) { cull(); return; }

    float opacity = uintBitsToFloat(t2.w);
    if (opacity < 1.0 / 255.0) { cull(); return; }
    vec3 p = u_cam_from_world * uintBitsToFloat(t0.xyz) + u_cam_t;
    if (p.z <= 0.01) { cull(); return; }

    vec4 c = uintBitsToFloat(t1);
    vec2 d = uintBitsToFloat(t2.xy);
    mat3 cov = mat3(c.x, c.y, c.z,  c.y, c.w, d.x,  c.z, d.x, d.y);
    mat3 cov_cam = u_cam_from_world * cov * transpose(u_cam_from_world);

    float fx = u_intrinsics.x, fy = u_intrinsics.y, cx = u_intrinsics.z, cy = u_intrinsics.w;
    float tan_x = 0.5 * u_size.x / fx, tan_y = 0.5 * u_size.y / fy;
    float tx = p.z * clamp(p.x / p.z, -(cx / fx + 0.3 * tan_x), (u_size.x - cx) / fx + 0.3 * tan_x);
    float ty = p.z * clamp(p.y / p.z, -(cy / fy + 0.3 * tan_y), (u_size.y - cy) / fy + 0.3 * tan_y);
    vec3 j0 = vec3(fx / p.z, 0.0, -fx * tx / (p.z * p.z));
    vec3 j1 = vec3(0.0, fy / p.z, -fy * ty / (p.z * p.z));
    vec3 s0 = cov_cam * j0, s1 = cov_cam * j1;
    float a = dot(j0, s0) + 0.3, b = dot(j0, s1), cc = dot(j1, s1) + 0.3;
    float det = max(a * cc - b * b, 1e-10);
    v_conic = vec3(cc / det, -b / det, a / det);

    // Reach: where opacity·exp(−r²/2λ) falls to 1/255 along the major axis (≤ 3.33 σ).
    float mid = 0.5 * (a + cc);
    float lambda = mid + sqrt(max(mid * mid - det, 0.1));
    float radius = ceil(sqrt(2.0 * log(255.0 * opacity) * lambda));
    vec2 centre = vec2(fx * p.x / p.z + cx, fy * p.y / p.z + cy);
    if (centre.x + radius <= 0.0 || centre.x - radius >= u_size.x || centre.y + radius <= 0.0
        || centre.y - radius >= u_size.y || !(radius > 0.0)) {
        cull();
        return;
    }

    vec3 rgb = vec3(float(t2.z & 255u), float((t2.z >> 8) & 255u), float((t2.z >> 16) & 255u)) / 255.0;
    if (u_palette || (flags & RECOLOURED) != 0u) rgb = state.rgb;
    v_colour = vec4(rgb, opacity);
    v_slot = slot;
    v_index = a_index;
    v_flags = flags;
    v_offset = a_corner * radius;
    vec2 pixel = centre + v_offset;
    gl_Position = vec4(2.0 * pixel.x / u_size.x - 1.0, 1.0 - 2.0 * pixel.y / u_size.y, 0.0, 1.0);
}
