// Which box-test kernel new TriangleRayCasters use (triangle_raycast.cpp): for tests and
// benchmarks that compare the kernels.
#pragma once

namespace vox::detail {

/// Whether TriangleRayCasters constructed from now on test a node's eight boxes at once with AVX2
/// (where the CPU has it; initially wherever it can) rather than four at a time (SSE2, or plain
/// lanes off x86). Both find the same hits. Returns whether AVX2 is now on. Thread-safe.
bool setTriangleCasterAvx2(bool enabled) noexcept;

}  // namespace vox::detail
