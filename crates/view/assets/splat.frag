#version 300 es
// Gaussian falloff as splatseg-render blends it: σ = ½(a·dx² + c·dy²) + b·dx·dy,
// α = min(0.99, opacity·exp(−σ)), skipped below 1/255. Colour pass: premultiplied, back to
// front. Id pass: the object slot + 1 as three bytes, written by the nearest Gaussian whose α
// reaches u_id_alpha at the pixel (drawn last, no blending); with u_index_pass, the Gaussian's
// index + 1 as four bytes instead (a lasso's front-most Gaussians).
precision highp float;
precision highp int;

uniform bool u_id_pass;
uniform bool u_index_pass;
uniform float u_id_alpha;

in vec2 v_offset;
flat in vec3 v_conic;
flat in vec4 v_colour;
flat in uint v_slot;
flat in uint v_index;
flat in uint v_flags;

out vec4 out_colour;

const uint SELECTED = 2u;
const uint HIGHLIGHT = 8u;
const uint PICKED = 16u;

void main() {
    vec2 d = v_offset;
    float sigma = 0.5 * (v_conic.x * d.x * d.x + v_conic.z * d.y * d.y) + v_conic.y * d.x * d.y;
    float alpha = min(0.99, v_colour.a * exp(-sigma));
    if (sigma < 0.0 || alpha < 1.0 / 255.0) discard;
    if (u_id_pass) {
        if (alpha < u_id_alpha) discard;
        if (u_index_pass) {
            uint i = v_index + 1u;
            out_colour = vec4(float(i & 255u), float((i >> 8) & 255u), float((i >> 16) & 255u), float((i >> 24) & 255u)) / 255.0;
            return;
        }
        uint id = v_slot + 1u;
        out_colour = vec4(float(id & 255u), float((id >> 8) & 255u), float((id >> 16) & 255u), 255.0) / 255.0;
        return;
    }
    vec3 rgb = v_colour.rgb;
    if ((v_flags & SELECTED) != 0u) rgb = mix(rgb, vec3(1.0, 0.85, 0.2), 0.5);
    if ((v_flags & HIGHLIGHT) != 0u) rgb = mix(rgb, vec3(1.0), 0.35);
    if ((v_flags & PICKED) != 0u) rgb = mix(rgb, vec3(0.1, 0.9, 1.0), 0.7);
    out_colour = vec4(rgb * alpha, alpha);
}
