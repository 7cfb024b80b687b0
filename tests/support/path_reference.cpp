#include "path_reference.h"

#include "scene/surface_shading.h"

#include <vox/lighting.h>

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>

namespace vox::reference {
namespace {

constexpr double kPi = std::numbers::pi;
/// Paths per independently seeded stream: small enough that one point alone still spreads over
/// every core, large enough that seeding a generator is noise.
constexpr std::uint32_t kChunkSamples = 1024;

/// splitmix64's finaliser: decorrelates the (seed, point, chunk) triples before they seed a
/// generator, so neighbouring points do not start from neighbouring states.
std::uint64_t mix(std::uint64_t x) {
    x += 0x9E3779B97F4A7C15ull;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
    return x ^ (x >> 31);
}

/// Uniform in [0, 1) from the top 53 bits: std::mt19937_64's output is fixed by the standard,
/// unlike std::uniform_real_distribution's, so results are the same with any standard library.
double uniform(std::mt19937_64& rng) { return double(rng() >> 11) * 0x1.0p-53; }

/// Running mean and sum of squared deviations of (r, g, b, luminance) samples (Welford), merged
/// by Chan et al.'s formula: exact for zero-variance fields, where Σx² − (Σx)²/N is not.
struct Moments {
    std::uint64_t n = 0;
    std::array<double, 4> mean{}, m2{};

    void add(Vec3d x) {
        const std::array<double, 4> v{x.x, x.y, x.z, luminance(x)};
        ++n;
        for (int c = 0; c < 4; ++c) {
            const double delta = v[c] - mean[c];
            mean[c] += delta / double(n);
            m2[c] += delta * (v[c] - mean[c]);
        }
    }
    void merge(const Moments& o) {
        if (o.n == 0) return;
        const double total = double(n + o.n);
        for (int c = 0; c < 4; ++c) {
            const double delta = o.mean[c] - mean[c];
            mean[c] += delta * double(o.n) / total;
            m2[c] += o.m2[c] + delta * delta * double(n) * double(o.n) / total;
        }
        n += o.n;
    }
    [[nodiscard]] IrradianceEstimate estimate() const {
        IrradianceEstimate e;
        e.samples = n;
        e.mean = {mean[0], mean[1], mean[2]};
        e.luminance = luminance(e.mean);
        if (n > 1) {
            const auto se = [&](int c) {
                return std::sqrt(std::max(0.0, m2[c]) / double(n - 1) / double(n));
            };
            e.standardError = {se(0), se(1), se(2)};
            e.luminanceStandardError = se(3);
        }
        return e;
    }
};

}  // namespace

double luminance(Vec3d rgb) { return 0.2126 * rgb.x + 0.7152 * rgb.y + 0.0722 * rgb.z; }

Vec3d cosineDirection(Vec3d n, double u1, double u2) {
    const double r = std::sqrt(u1), phi = 2 * kPi * u2;
    return normalize(OrthonormalFrame(n).toWorld(r * std::cos(phi), r * std::sin(phi),
                                                 std::sqrt(std::max(0.0, 1.0 - u1))));
}

double IrradianceEstimate::relativeStandardError() const {
    if (luminance > 0) return luminanceStandardError / luminance;
    return luminanceStandardError > 0 ? std::numeric_limits<double>::infinity() : 0.0;
}

/// A shaded path vertex, turned towards the ray that found it.
struct PathReference::Vertex {
    Vec3d position;
    Vec3d side;    ///< unit geometric normal on the side the ray arrived from
    Vec3d normal;  ///< unit shading normal, flipped onto that side
    Vec3d albedo;
    Vec3d emission;
};

PathReference::PathReference(const Scene& scene) : scene_(scene), caster_(scene, false) {
    for (const Light& light : scene.lights)
        if (!light.dynamic) lights_.push_back(&light);
    double magnitude = 0;
    for (const Mesh& mesh : scene.meshes) {
        if (mesh.dynamic) continue;
        for (const Vec3f& p : mesh.positions)
            magnitude = std::max(
                {magnitude, double(std::abs(p.x)), double(std::abs(p.y)), double(std::abs(p.z))});
    }
    offset_ = 1e-5 * std::max(magnitude, std::numeric_limits<double>::min());
}

bool PathReference::intersect(const Ray& ray, Vertex& out) const {
    const SurfaceHit hit = caster_.castSurface(ray);
    if (!hit.hit) return false;
    const Mesh& mesh = scene_.meshes[hit.mesh];
    std::array<Vec3d, 3> corners;
    for (int k = 0; k < 3; ++k)
        corners[k] =
            vec3Cast<double>(mesh.positions[mesh.indices[3 * std::size_t{hit.triangle} + k]]);
    // The point from the barycentric weights in double precision lies on the triangle's plane,
    // unlike origin + t·d with t rounded to float: offsets then measure from the surface itself.
    out.position = corners[0] * hit.barycentric.x + corners[1] * hit.barycentric.y +
                   corners[2] * hit.barycentric.z;
    const detail::SurfaceSample s =
        detail::shadeTriangle(scene_, {hit.mesh, hit.triangle}, corners, hit.barycentric, 0);
    // Two-sided: the geometric normal decides the side (robust where a bent shading normal is
    // nearly tangent), and the shading normal follows it.
    out.side =
        dot(hit.geometricNormal, ray.direction) < 0 ? hit.geometricNormal : -hit.geometricNormal;
    out.normal = dot(s.normal, out.side) < 0 ? -s.normal : s.normal;
    out.albedo = {s.color.x, s.color.y, s.color.z};
    out.emission = vec3Cast<double>(s.emission);
    return true;
}

Vec3d PathReference::direct(Vec3d position, Vec3d normal, Vec3d side) const {
    Vec3d sum{0, 0, 0};
    const Vec3d origin = position + side * offset_;
    for (const Light* light : lights_) {
        LightArrival arrival;
        if (!lightArrival(*light, position, arrival)) continue;
        const double cosine = dot(normal, arrival.toLight);
        if (cosine <= 0) continue;
        // Occluders strictly between the surface and the light; a point light lying on a surface
        // is not shadowed by that surface.
        const double tMax = std::isfinite(arrival.distance)
                                ? arrival.distance - offset_
                                : std::numeric_limits<double>::infinity();
        if (tMax <= 0 || caster_.castSurface({origin, arrival.toLight}, tMax).hit) continue;
        sum += arrival.irradiance * cosine;
    }
    return sum;
}

Vec3d PathReference::directIrradiance(const SurfacePoint& point) const {
    return direct(point.position, point.normal, point.normal);
}

Vec3d PathReference::onceScattered(const Vertex& vertex) const {
    Vec3d l = vertex.emission;
    if (vertex.albedo.x > 0 || vertex.albedo.y > 0 || vertex.albedo.z > 0)
        l += vertex.albedo * direct(vertex.position, vertex.normal, vertex.side) * (1.0 / kPi);
    return l;
}

std::vector<PointIrradiance> PathReference::estimate(std::span<const SurfacePoint> points,
                                                     const PathReferenceOptions& options) const {
    const std::uint32_t chunks = (options.samples + kChunkSamples - 1) / kChunkSamples;
    // One slot per (point, chunk) task: E1 and E2 moments, merged in chunk order afterwards so
    // the sums never depend on which thread ran what.
    std::vector<std::array<Moments, 2>> partial(points.size() * chunks);
    tbb::parallel_for(std::size_t{0}, partial.size(), [&](std::size_t task) {
        const std::size_t p = task / chunks;
        const std::uint32_t chunk = static_cast<std::uint32_t>(task % chunks);
        const std::uint32_t count =
            std::min(kChunkSamples, options.samples - chunk * kChunkSamples);
        std::mt19937_64 rng(mix(mix(mix(options.seed) ^ p) ^ chunk));
        const Vec3d n = normalize(points[p].normal);
        const Vec3d origin = points[p].position + n * offset_;
        auto& [e1, e2] = partial[task];
        for (std::uint32_t i = 0; i < count; ++i) {
            // Four numbers per path whatever happens on it.
            const double u1 = uniform(rng), u2 = uniform(rng), u3 = uniform(rng), u4 = uniform(rng);
            Vec3d first{0, 0, 0}, second{0, 0, 0};
            Vertex y;
            if (intersect({origin, cosineDirection(n, u1, u2)}, y)) {
                first = onceScattered(y) * kPi;
                if (y.albedo.x > 0 || y.albedo.y > 0 || y.albedo.z > 0) {
                    const Vec3d w = cosineDirection(y.normal, u3, u4);
                    Vertex z;
                    // A direction of the shading hemisphere below the geometric surface (bent
                    // normals only) would pass through it: no light from there.
                    if (dot(w, y.side) > 0 && intersect({y.position + y.side * offset_, w}, z))
                        second = y.albedo * onceScattered(z) * kPi;
                }
            }
            e1.add(first);
            e2.add(second);
        }
    });
    std::vector<PointIrradiance> out(points.size());
    tbb::parallel_for(std::size_t{0}, points.size(), [&](std::size_t p) {
        std::array<Moments, 2> total;
        for (std::uint32_t c = 0; c < chunks; ++c)
            for (int b = 0; b < 2; ++b) total[b].merge(partial[p * chunks + c][b]);
        out[p].bounce1 = total[0].estimate();
        out[p].bounce2 = total[1].estimate();
        const Vec3d n = normalize(points[p].normal);
        out[p].direct = direct(points[p].position, n, n);
    });
    return out;
}

}  // namespace vox::reference
