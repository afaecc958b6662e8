#pragma once
// For the GL tests of the renderer's units: a context of their own (planet/gl/src/GlContext.hpp),
// made current, without a Renderer. Skips the test without a display.

#include "../../planet/gl/src/GlContext.hpp"
#include "GlTestSupport.hpp"

#define OPEN_GL_CONTEXT(var)                                                                       \
  if (!tellus::planet::gltest::haveDisplay())                                                      \
    GTEST_SKIP() << "no DISPLAY: run the gl label under xvfb-run";                                 \
  auto var##Made = tellus::planet::GlContext::create({});                                          \
  ASSERT_TRUE(var##Made.has_value()) << var##Made.error();                                         \
  const tellus::planet::GlContext& var = **var##Made
