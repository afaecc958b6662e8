// Unlit texturing: the node's texture (or its fallback) through the uv transform.
in vec2 vUv;

uniform sampler2D uTexture;

out vec4 fragColor;

void main() {
  fragColor = vec4(texture(uTexture, vUv).rgb, 1.0);
}
