// What this CPU can run, for the kernels built for instruction sets beyond the compiler's target
// (functions with [[gnu::target]]), which are called only where the CPU has them.
#pragma once

namespace vox::detail {

/// The instruction sets the SIMD kernels choose by, asked once; all false where the compiler
/// cannot ask (outside x86 or without GCC's builtins).
struct CpuFeatures {
#if (defined(__x86_64__) || defined(__i386__)) && (defined(__GNUC__) || defined(__clang__))
    // (__builtin_cpu_supports also asks the OS whether it saves the registers.)
    bool avx2 = __builtin_cpu_supports("avx2") != 0;
    bool avx512f = __builtin_cpu_supports("avx512f") != 0;
    bool avx512vl = __builtin_cpu_supports("avx512vl") != 0;
#else
    bool avx2 = false;
    bool avx512f = false;
    bool avx512vl = false;
#endif
};

/// This CPU's features, asked on the first call.
inline const CpuFeatures& cpuFeatures() noexcept {
    static const CpuFeatures features;
    return features;
}

}  // namespace vox::detail
