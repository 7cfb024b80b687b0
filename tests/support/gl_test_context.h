// One OpenGL 4.5 context per test program (creating one is the slow part on llvmpipe), and the
// skip for machines that have no OpenGL 4.5 at all.
#pragma once

#include <vox/runtime/gl_context.h>

#include <gtest/gtest.h>

#include <memory>
#include <string>

namespace vox::test {

/// The program's context, or null with the reason in @p whyNot where none can be made.
inline runtime::HeadlessGlContext* glContext(std::string* whyNot = nullptr) {
    static std::string reason;
    static std::unique_ptr<runtime::HeadlessGlContext> context = [] {
        try {
            return std::make_unique<runtime::HeadlessGlContext>();
        } catch (const runtime::RuntimeError& e) {
            reason = e.what();
            return std::unique_ptr<runtime::HeadlessGlContext>();
        }
    }();
    if (whyNot != nullptr) *whyNot = reason;
    return context.get();
}

}  // namespace vox::test

/// Declares `gl`, the program's context with its debug messages cleared, or skips the test with
/// the reason where this machine has no OpenGL 4.5 (only there: everywhere else a GL failure
/// fails).
#define REQUIRE_GL()                                                         \
    std::string whyNoGl;                                                     \
    vox::runtime::HeadlessGlContext* gl = vox::test::glContext(&whyNoGl);    \
    if (gl == nullptr) GTEST_SKIP() << "no OpenGL 4.5 context: " << whyNoGl; \
    gl->clearDebugMessages()
