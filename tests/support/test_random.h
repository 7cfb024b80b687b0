// Seeded random numbers for tests: uniform reals, indices and unit vectors, the same sequence on
// every platform's libstdc++ for a seed.
#pragma once

#include <vox/base/math.h>

#include <cmath>
#include <cstdint>
#include <random>

namespace vox::test {

struct Rng {
    std::mt19937_64 engine;
    explicit Rng(std::uint64_t seed) : engine(seed) {}
    double uniform(double lo = 0, double hi = 1) {
        return std::uniform_real_distribution<double>(lo, hi)(engine);
    }
    std::uint32_t below(std::uint32_t n) {
        return std::uniform_int_distribution<std::uint32_t>(0, n - 1)(engine);
    }
    /// A unit vector, uniform over the sphere.
    Vec3d unit() {
        for (;;) {
            const Vec3d v{uniform(-1, 1), uniform(-1, 1), uniform(-1, 1)};
            const double l = length(v);
            if (l > 0.1 && l <= 1) return v / l;
        }
    }
    /// A unit vector within @p maxAngle of @p axis (uniform over that cap).
    Vec3d around(Vec3d axis, double maxAngle) {
        for (;;) {
            const Vec3d v = unit();
            if (dot(v, axis) >= std::cos(maxAngle)) return v;
        }
    }
};

}  // namespace vox::test
