#pragma once
/**
 * @file Depth.hpp
 * @brief The depth conventions of every scene pass (issues #5 and #8): a 32-bit float depth
 * buffer, reversed Z (the projection of Camera.hpp, reversedZInfinitePerspective, puts the near
 * plane at depth 1 and infinity at 0: depth = near / distance, whose float keeps the same relative
 * precision, about 1.2e-7, at every distance), depth in [0, 1] through glClipControl, cleared to 0
 * (infinity), nearer wins with GL_GREATER. One frustum holds 0.1 m and 1e9 m
 * (`RenderExtremesGl.DepthResolvesOneInAHundredThousandFromATenthOfAMetreToABillionMetres`).
 * GL-private; used by Renderer.cpp and the extremes tests.
 */

#include <epoxy/gl.h>

namespace tellus::planet {

inline constexpr GLenum kDepthFormat = GL_DEPTH_COMPONENT32F;

/** Sets the depth state of a scene pass on the bound framebuffer (before its glClear).
 * clipControl: glClipControl is there (OpenGL 4.5 or ARB_clip_control). */
inline void beginReversedZ(bool clipControl) {
  if (clipControl) glClipControl(GL_LOWER_LEFT, GL_ZERO_TO_ONE);
  glClearDepth(0.0);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_GREATER);
}

} // namespace tellus::planet
