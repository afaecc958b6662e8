// Node meshes: positions relative to the node's centre (float), one model-view-projection per
// node computed in double relative to the camera on the CPU, so nothing large reaches the GPU.
// The #version line is prepended by the renderer (450 core or 330 core).
layout(location = 0) in vec3 aPosition;
layout(location = 1) in vec2 aUvNode;

uniform mat4 uMvp;
// uvTexture = uvNode * uUv.xy + uUv.zw (own texture, an ancestor's part, or the global texture)
uniform vec4 uUv;

out vec2 vUv;

void main() {
  vUv = aUvNode * uUv.xy + uUv.zw;
  gl_Position = uMvp * vec4(aPosition, 1.0);
}
