#version 300 es
precision highp float;
uniform vec4 u_colour;
out vec4 out_colour;
void main() {
    out_colour = vec4(u_colour.rgb * u_colour.a, u_colour.a);
}
