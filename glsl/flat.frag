#version 460
// A flat colour: graphics work whose only purpose is to exist (timestamp ordering test).
layout(location = 0) out vec4 colour;
void main() {
    colour = vec4(gl_FragCoord.xy * 1e-3, 0.5, 1.0);
}
