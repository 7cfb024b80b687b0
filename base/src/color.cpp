#include <vox/base/color.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <limits>

namespace vox {

float srgbToLinear(float v) {
    return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
}

float linearToSrgb(float v) {
    return v <= 0.0031308f ? v * 12.92f : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
}

double linearToSrgbSlope(double v) {
    return v <= 0.0031308 ? 12.92 : 1.055 / 2.4 * std::pow(v, 1.0 / 2.4 - 1.0);
}

std::uint8_t srgbCode(float linear) {
    const float v = std::clamp(linear, 0.0f, 1.0f);
    const auto direct = [](float x) {
        return static_cast<std::uint8_t>(std::lround(255.0f * linearToSrgb(x)));
    };
    if (!(v >= 0.0f && v <= 1.0f)) return direct(v);  // NaN, as the formula takes it
    // direct() never falls as its argument rises (checked over every float of [0, 1]; the test
    // checks it around every step): the code is the highest whose lowest value v reaches, and a
    // bucket of v (the first code of the bucket's start) leaves at most one step to take: no
    // bucket spans two (direct() of its start and of the float below its end differ by at most 1,
    // checked for all 4096).
    constexpr int kBuckets = 4096;
    struct Tables {
        std::array<float, 257> lowest{};  // of code k, k = 0…255, then +inf
        std::array<std::uint8_t, kBuckets + 1> first{};
    };
    static const Tables tables = [&] {
        Tables t;
        const std::uint32_t oneBits = std::bit_cast<std::uint32_t>(1.0f);
        for (int k = 1; k < 256; ++k) {
            std::uint32_t lo = 0, hi = oneBits;  // direct(bits hi) ≥ k
            while (lo < hi) {
                const std::uint32_t mid = lo + (hi - lo) / 2;
                if (direct(std::bit_cast<float>(mid)) >= k)
                    hi = mid;
                else
                    lo = mid + 1;
            }
            t.lowest[static_cast<std::size_t>(k)] = std::bit_cast<float>(lo);
        }
        t.lowest[256] = std::numeric_limits<float>::infinity();
        for (int b = 0; b <= kBuckets; ++b)
            t.first[static_cast<std::size_t>(b)] = direct(static_cast<float>(b) / kBuckets);
        return t;
    }();
    // v·kBuckets is exact (a power of two), so the bucket's start is at most v.
    std::size_t code = tables.first[static_cast<std::size_t>(v * kBuckets)];
    code += v >= tables.lowest[code + 1] ? 1 : 0;  // no branch: whether to step is a coin toss
    return static_cast<std::uint8_t>(code);
}

Vec3f shadeHeadlight(Vec3f normal, Vec3f toEye, Vec3f albedo) {
    Vec3f n = normal;
    // Facing the viewer: a sheet seen from behind shades like its front.
    if (dot(n, toEye) < 0) n = -n;
    const float diffuse = std::max(0.0f, dot(n, toEye));
    // With the light at the eye, the mirror direction of the light is 2(n·l)n − l.
    const Vec3f reflected = n * (2 * dot(n, toEye)) - toEye;
    const float specular = 0.25f * std::pow(std::max(0.0f, dot(reflected, toEye)), 32.0f);
    return albedo * (0.1f + 0.9f * diffuse) + Vec3f{specular, specular, specular};
}

}  // namespace vox
