// The direct dome's mask (issue #7): a ring from just inside the image's circle out to the
// framebuffer's border, in window pixels; the fragment shader paints what lies outside the
// circle black. The renderer prepends #version.
layout(location = 0) in vec2 aPixel; // window pixels
uniform vec2 uViewport;              // width, height in pixels

void main() {
  gl_Position = vec4(aPixel / uViewport * 2.0 - 1.0, 0.0, 1.0);
}
