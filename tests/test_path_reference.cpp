// The path-traced reference (tests/support/path_reference.h) against closed forms: closed
// emissive boxes (E1 = π·Le, E2 = π·ρ·Le), form factors of parallel rectangles (which only
// cosine-weighted sampling with the right weight reproduces), punctual lights (I·cos θ / d²),
// shadows, self-intersection, two-sided surfaces, standard errors and determinism. Also
// TriangleRayCaster::castSurface, which the reference is built on. Scenes are built in code.
#include "path_reference.h"
#include "scene_builder.h"
#include "render/triangle_raycast_kernels.h"

#include <vox/triangle_raycast.h>
#include <vox/util/parallel.h>

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <numbers>

namespace {

using vox::Vec3d;
using vox::Vec3f;
using vox::reference::PathReference;
using vox::reference::PathReferenceOptions;
using vox::reference::SurfacePoint;
using vox::test::addBox;
using vox::test::addMaterial;
using vox::test::addQuad;

constexpr double kPi = std::numbers::pi;

/// Form factor from a differential area to a parallel rectangle X·h by Y·h at height h with one
/// corner straight above it (Howell's catalogue, C-11).
double cornerFormFactor(double x, double y) {
    const double a = std::sqrt(1 + x * x), b = std::sqrt(1 + y * y);
    return (x / a * std::atan(y / a) + y / b * std::atan(x / b)) / (2 * kPi);
}

/// Form factor from the origin (normal +y) to the rectangle [x0, x1] × [z0, z1] at height h,
/// x0 < 0 < x1 and z0 < 0 < z1: four corner rectangles.
double formFactor(double x0, double x1, double z0, double z1, double h) {
    double f = 0;
    for (double x : {-x0, x1})
        for (double z : {-z0, z1}) f += cornerFormFactor(x / h, z / h);
    return f;
}

void expectNear(Vec3d actual, Vec3d expected, double relative, const char* what) {
    for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(actual[c], expected[c], relative * std::abs(expected[c]) + 1e-12)
            << what << " channel " << c;
}

/// |estimate − exact| within four standard errors (plus rounding), per channel.
void expectWithinNoise(const vox::reference::IrradianceEstimate& e, Vec3d exact, const char* what) {
    for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(e.mean[c], exact[c], 4 * e.standardError[c] + 1e-9 * std::abs(exact[c]))
            << what << " channel " << c;
}

TEST(PathReference, ClosedEmissiveBlackBoxGivesPiLeAndNoSecondBounce) {
    vox::Scene scene;
    const Vec3f le{1.0f, 0.5f, 0.25f};
    addBox(scene, {-1, -1, -1}, {1, 1, 1}, addMaterial(scene, {0, 0, 0}, le), true);
    const PathReference reference(scene);
    const std::vector<SurfacePoint> points{
        {{0, 0, 0}, vox::normalize(Vec3d{1, 2, 3})},               // the centre, any normal
        {{0.3, -1, 0.2}, {0, 1, 0}},                               // on the floor
        {{0.99, 0.99, 0.99}, vox::normalize(Vec3d{-1, -1, -1})}};  // near a corner
    const auto result = reference.estimate(points, {.samples = 2000, .seed = 7});
    const Vec3d exact{kPi * le.x, kPi * le.y, kPi * le.z};
    for (const auto& r : result) {
        // Every path sees the box: no noise at all.
        expectNear(r.bounce1.mean, exact, 1e-12, "E1");
        EXPECT_LT(r.bounce1.relativeStandardError(), 1e-9);
        EXPECT_EQ(r.bounce1.samples, 2000u);
        expectNear(r.bounce2.mean, {0, 0, 0}, 0, "E2 with albedo 0");
        EXPECT_EQ(r.bounce2.relativeStandardError(), 0.0);
        expectNear(r.direct, {0, 0, 0}, 0, "no punctual lights");
    }
}

TEST(PathReference, ClosedEmissiveGreyBoxGivesPiRhoLeForTheSecondBounce) {
    // Fronts facing out: the reference treats every surface as two-sided.
    vox::Scene scene;
    const Vec3f le{2.0f, 1.0f, 1.0f}, rho{0.5f, 0.25f, 0.8f};
    addBox(scene, {-1, -2, -1}, {3, 1, 1}, addMaterial(scene, rho, le), false);
    const PathReference reference(scene);
    const std::vector<SurfacePoint> points{
        {{0, 0, 0}, {0, 1, 0}}, {{2.5, -2, 0.5}, {0, 1, 0}}, {{-1, 0.5, 0}, {1, 0, 0}}};
    const auto result = reference.estimate(points, {.samples = 3000});
    for (const auto& r : result) {
        expectNear(r.bounce1.mean, {kPi * le.x, kPi * le.y, kPi * le.z}, 1e-9, "E1 = π·Le");
        expectNear(r.bounce2.mean, {kPi * rho.x * le.x, kPi * rho.y * le.y, kPi * rho.z * le.z},
                   1e-6, "E2 = π·ρ·Le");
    }
}

TEST(PathReference, EmissiveRectangleGivesItsFormFactorWithTheRightStandardError) {
    // An emitter above, nothing else: E1 = π·Le·F. Uniform hemisphere sampling, or cosine
    // sampling with a wrong weight, lands far outside the noise.
    vox::Scene scene;
    const Vec3f le{3.0f, 2.0f, 1.0f};
    const double h = 1.0;
    addQuad(scene, {-1.5, h, -0.5}, {0, 0, 2.5}, {2.5, 0, 0},
            addMaterial(scene, {0.7f, 0.7f, 0.7f}, le));  // front faces up, away: two-sided
    const PathReference reference(scene);
    const std::uint32_t samples = 1u << 16;
    const auto result = reference.estimate(std::vector<SurfacePoint>{{{0, 0, 0}, {0, 1, 0}}},
                                           {.samples = samples, .seed = 3});
    const double f = formFactor(-1.5, 1.0, -0.5, 2.0, h);
    const Vec3d exact{kPi * le.x * f, kPi * le.y * f, kPi * le.z * f};
    const auto& e1 = result[0].bounce1;
    expectWithinNoise(e1, exact, "E1 = π·Le·F");
    // Each sample is π·Le or 0 with probability F: standard error π·Le·√(F(1 − F)/N).
    for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(e1.standardError[c], exact[c] / f * std::sqrt(f * (1 - f) / samples),
                    0.02 * e1.standardError[c]);
    EXPECT_NEAR(e1.relativeStandardError(), std::sqrt((1 - f) / (f * samples)),
                0.02 * e1.relativeStandardError());
    // Light leaving the emitter's far side can only escape.
    expectNear(result[0].bounce2.mean, {0, 0, 0}, 0, "E2");
}

TEST(PathReference, PunctualLightsGiveIntensityTimesCosineOverDistanceSquared) {
    vox::Scene scene;
    addQuad(scene, {-100, 0, -100}, {0, 0, 200}, {200, 0, 0},
            addMaterial(scene, {0.5f, 0.5f, 0.5f}));
    vox::Light point;
    point.type = vox::Light::Type::Point;
    point.color = {1.0f, 0.5f, 0.25f};
    point.intensity = 10;
    point.position = {0, 2, 0};
    vox::Light sun;
    sun.type = vox::Light::Type::Directional;
    sun.color = {1, 1, 1};
    sun.intensity = 3;
    sun.direction = {0.6f, -0.8f, 0};
    vox::Light moving = point;  // dynamic lights are not part of a static bake
    moving.dynamic = true;
    moving.intensity = 1000;
    scene.lights = {point, sun, moving};
    const PathReference reference(scene);

    const Vec3d e = reference.directIrradiance({{1.5, 0, 0}, {0, 1, 0}});
    // d² = 2² + 1.5² = 6.25, cos θ = 2 / 2.5; the sun at cos θ = 0.8.
    const double cosine = 0.8, d2 = 6.25;
    expectNear(e,
               Vec3d{10 * cosine / d2 * 1.0 + 3 * 0.8, 10 * cosine / d2 * 0.5 + 3 * 0.8,
                     10 * cosine / d2 * 0.25 + 3 * 0.8},
               1e-5, "E_direct");
    // The floor's other side faces away from both lights (and is in the floor's shadow).
    expectNear(reference.directIrradiance({{1.5, 0, 0}, {0, -1, 0}}), {0, 0, 0}, 0, "underside");
    // The same through estimate(), which also reports it.
    const auto result =
        reference.estimate(std::vector<SurfacePoint>{{{1.5, 0, 0}, {0, 1, 0}}}, {.samples = 1});
    expectNear(result[0].direct, e, 1e-12, "estimate().direct");
    // Nothing above the floor reflects: no indirect light.
    expectNear(result[0].bounce1.mean, {0, 0, 0}, 0, "E1");
}

TEST(PathReference, ShadowRaysStopAtOccludersButNotAtTheSurfaceItself) {
    vox::Scene scene;
    const std::uint32_t grey = addMaterial(scene, {0.5f, 0.5f, 0.5f});
    addQuad(scene, {-10, 0, -10}, {0, 0, 20}, {20, 0, 0}, grey);
    addQuad(scene, {2, 1, -0.5}, {0, 0, 1}, {1, 0, 0}, grey);  // a tile at height 1 over x ∈ [2, 3]
    vox::Light light;
    light.position = {2.5f, 2, 0};
    light.intensity = 4;
    scene.lights = {light};
    const PathReference reference(scene);
    expectNear(reference.directIrradiance({{2.5, 0, 0}, {0, 1, 0}}), {0, 0, 0}, 0,
               "under the tile");
    expectNear(reference.directIrradiance({{2.5, 1, 0}, {0, 1, 0}}), {4, 4, 4}, 1e-4,
               "on the tile (4 / 1²), no self-shadow");
    // Grazing: the light 1e-3 above the plane, 1 away along it.
    const double d2 = 1 + 1e-6, cosine = 1e-3 / std::sqrt(d2);
    scene.lights[0].position = {-5, 1e-3f, 0};
    const PathReference grazing(scene);
    const Vec3d e = grazing.directIrradiance({{-4, 0, 0}, {0, 1, 0}});
    EXPECT_NEAR(e.x, 4 * cosine / d2, 1e-3 * 4 * cosine / d2);
}

TEST(PathReference, LightReflectedOnceByATwoSidedCeiling) {
    // A grey rectangle above the point, its front facing up (away), lit from below by a sun at
    // 30° from the vertical: L1 = ρ/π · I·cos 30° on its lower side, so E1 = ρ·I·cos 30°·F. The
    // light can reflect only once: E2 = 0.
    vox::Scene scene;
    const Vec3f rho{0.5f, 0.4f, 0.3f};
    const double h = 0.8;
    addQuad(scene, {-1, h, -1.2}, {0, 0, 2.2}, {2.0, 0, 0}, addMaterial(scene, rho));
    vox::Light sun;
    sun.type = vox::Light::Type::Directional;
    sun.intensity = 2;
    sun.direction = {0.5f, float(std::sqrt(3.0) / 2), 0};
    scene.lights = {sun};
    const PathReference reference(scene);
    const auto result = reference.estimate(std::vector<SurfacePoint>{{{0, 0, 0}, {0, 1, 0}}},
                                           {.samples = 1u << 15});
    const double f = formFactor(-1, 1, -1.2, 1.0, h), e = 2 * std::sqrt(3.0) / 2 * f;
    expectWithinNoise(result[0].bounce1, {rho.x * e, rho.y * e, rho.z * e}, "E1 = ρ·I·cos θ·F");
    EXPECT_LT(result[0].bounce1.relativeStandardError(), 0.01);
    expectNear(result[0].bounce2.mean, {0, 0, 0}, 0, "E2");
    // The point itself is not lit (the sun shines upwards).
    expectNear(result[0].direct, {0, 0, 0}, 0, "E_direct");
}

TEST(PathReference, EmissionReflectedOnceBetweenParallelPlanesIsTheSecondBounce) {
    // An emissive floor and a grey ceiling 1 apart, 200 wide. From a point on the floor, E1 = 0
    // (the ceiling does not emit, and the floor must not see itself), E2 = π·ρ·Le (less the
    // 1e-4 that escapes past the edges). With a black ceiling, E2 = 0 too.
    for (const Vec3f rho : {Vec3f{0.5f, 0.25f, 0.8f}, Vec3f{0, 0, 0}}) {
        vox::Scene scene;
        const Vec3f le{1, 2, 3};
        addQuad(scene, {-100, 0, -100}, {0, 0, 200}, {200, 0, 0},
                addMaterial(scene, {0.3f, 0.3f, 0.3f}, le));
        addQuad(scene, {-100, 1, -100}, {200, 0, 0}, {0, 0, 200}, addMaterial(scene, rho));
        const PathReference reference(scene);
        const auto result = reference.estimate(
            std::vector<SurfacePoint>{{{0.25, 0, -0.5}, {0, 1, 0}}, {{3, 1, 2}, {0, -1, 0}}},
            {.samples = 4096});
        const auto& floor = result[0];
        expectNear(floor.bounce1.mean, {0, 0, 0}, 0, "E1 on the floor");
        expectNear(floor.bounce2.mean, {kPi * rho.x * le.x, kPi * rho.y * le.y, kPi * rho.z * le.z},
                   2e-3, "E2 on the floor");
        // On the ceiling, facing down: E1 = π·Le; E2 = 0 (the floor's reflections reach the
        // ceiling only after the ceiling's own).
        expectNear(result[1].bounce1.mean, {kPi * le.x, kPi * le.y, kPi * le.z}, 2e-3,
                   "E1 on the ceiling");
        expectNear(result[1].bounce2.mean, {0, 0, 0}, 0, "E2 on the ceiling");
    }
}

TEST(PathReference, ResultsDependOnTheSeedButNotOnTheThreadCount) {
    vox::Scene scene;
    addBox(scene, {-1, 0, -1}, {1, 2, 1}, addMaterial(scene, {0.7f, 0.6f, 0.5f}), true);
    addQuad(scene, {-0.3, 1.99, -0.3}, {0.6, 0, 0}, {0, 0, 0.6},
            addMaterial(scene, {0, 0, 0}, {5, 5, 5}));
    vox::Light light;
    light.position = {0.2f, 1.5f, 0.1f};
    light.intensity = 2;
    scene.lights = {light};
    const PathReference reference(scene);
    const std::vector<SurfacePoint> points{
        {{0, 0, 0}, {0, 1, 0}}, {{-1, 1, 0.3}, {1, 0, 0}}, {{0.5, 2, 0.5}, {0, -1, 0}}};
    const PathReferenceOptions options{.samples = 3000,
                                       .seed = 11};  // not a whole number of chunks
    const auto run = [&](int threads) {
        const vox::ThreadLimit limit(threads);
        return reference.estimate(points, options);
    };
    const auto one = run(1), two = run(2);
    for (std::size_t p = 0; p < points.size(); ++p) {
        EXPECT_EQ(one[p].bounce1.mean, two[p].bounce1.mean);
        EXPECT_EQ(one[p].bounce1.standardError, two[p].bounce1.standardError);
        EXPECT_EQ(one[p].bounce2.mean, two[p].bounce2.mean);
        EXPECT_EQ(one[p].direct, two[p].direct);
        EXPECT_EQ(one[p].bounce1.samples, 3000u);
        EXPECT_GT(one[p].bounce1.luminance, 0);
        EXPECT_GT(one[p].bounce2.luminance, 0);
    }
    const auto other = reference.estimate(points, {.samples = 3000, .seed = 12});
    EXPECT_NE(other[0].bounce1.mean, one[0].bounce1.mean);
    // Different seeds agree within their noise.
    for (std::size_t p = 0; p < points.size(); ++p) {
        const double se = std::hypot(one[p].bounce1.luminanceStandardError,
                                     other[p].bounce1.luminanceStandardError);
        EXPECT_NEAR(one[p].bounce1.luminance, other[p].bounce1.luminance, 5 * se);
    }
}

TEST(TriangleRayCaster, CastSurfaceReportsTheTriangleItsWeightsAndItsWindingNormal) {
    vox::Scene scene;
    const std::uint32_t grey = addMaterial(scene, {0.5f, 0.5f, 0.5f});
    addQuad(scene, {-1, -1, 0}, {2, 0, 0}, {0, 2, 0}, grey);  // z = 0, front +z
    addQuad(scene, {-1, -1, 2}, {0, 2, 0}, {2, 0, 0}, grey);  // z = 2, front −z
    addQuad(scene, {-1, -1, 5}, {2, 0, 0}, {0, 2, 0}, grey);
    scene.meshes.back().dynamic = true;  // left out by default
    const vox::TriangleRayCaster caster(scene);
    for (const Vec3d dir : {Vec3d{0.1, 0.2, 1}, Vec3d{-0.3, 0.1, -1}}) {
        const vox::Ray ray{{0.2, -0.4, 1}, vox::normalize(dir)};
        const vox::SurfaceHit hit = caster.castSurface(ray);
        const vox::CastHit cast = caster.cast(ray);
        ASSERT_TRUE(hit.hit);
        EXPECT_EQ(hit.t, double(cast.t));
        EXPECT_EQ(hit.iterations, cast.iterations);
        EXPECT_EQ(hit.mesh, dir.z > 0 ? 1u : 0u);
        const vox::Mesh& mesh = scene.meshes[hit.mesh];
        Vec3d p{0, 0, 0};
        for (int k = 0; k < 3; ++k) {
            const Vec3f c =
                mesh.positions[mesh.indices[3 * std::size_t{hit.triangle} + std::size_t(k)]];
            p += Vec3d{c.x, c.y, c.z} * hit.barycentric[k];
            EXPECT_GE(hit.barycentric[k], -1e-6);
        }
        const Vec3d at = ray.origin + ray.direction * hit.t;
        EXPECT_NEAR(vox::length(p - at), 0, 1e-6);
        // The winding normal, not turned towards the ray (both quads face the ray's origin here).
        EXPECT_EQ(hit.geometricNormal, (Vec3d{0, 0, dir.z > 0 ? -1.0 : 1.0}));
    }
    // From outside the pair, the far side of a front face: the normal still follows the winding.
    const vox::SurfaceHit back = caster.castSurface({{0, 0, -1}, {0, 0, 1}});
    ASSERT_TRUE(back.hit);
    EXPECT_EQ(back.geometricNormal, (Vec3d{0, 0, 1}));
    EXPECT_NEAR(back.t, 1, 1e-6);
    // tMax: the plane at distance 1 is beyond 0.5; the dynamic quad is absent.
    EXPECT_FALSE(caster.castSurface({{0, 0, -1}, {0, 0, 1}}, 0.5).hit);
    EXPECT_FALSE(caster.castSurface({{0, 0, 3}, {0, 0, 1}}).hit);
}

/// Möller–Trumbore on one triangle, in the caster's float operations: t of a hit, or +inf.
float intersectOne(Vec3f o, Vec3f d, Vec3f v0, Vec3f v1, Vec3f v2) {
    const Vec3f e1 = v1 - v0, e2 = v2 - v0;
    const Vec3f p = vox::cross(d, e2);
    const float det = vox::dot(e1, p);
    const float miss = std::numeric_limits<float>::infinity();
    if (det == 0.0f) return miss;
    const float invDet = 1.0f / det;
    const Vec3f s = o - v0;
    const float u = vox::dot(s, p) * invDet;
    if (u < 0.0f || u > 1.0f) return miss;
    const Vec3f q = vox::cross(s, e1);
    const float v = vox::dot(d, q) * invDet;
    if (v < 0.0f || u + v > 1.0f) return miss;
    const float t = vox::dot(e2, q) * invDet;
    return t >= 0.0f ? t : miss;
}

// The BVH must find every ray's nearest triangle: against a test of every triangle, on a soup of
// overlapping triangles (deep, with boxes that overlap) and axis-aligned quads (flat boxes, and
// rays along the axes that run in their planes, where a slab test divides 0 by 0).
TEST(TriangleRayCaster, FindsTheNearestOfEveryTriangle) {
    vox::Scene scene;
    const std::uint32_t grey = addMaterial(scene, {0.5f, 0.5f, 0.5f});
    std::mt19937 random(7);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    vox::Mesh soup;
    soup.material = grey;
    for (std::uint32_t t = 0; t < 3000; ++t) {
        const Vec3f centre{unit(random), unit(random), unit(random)};
        for (int k = 0; k < 3; ++k) {
            soup.positions.push_back(centre + Vec3f{unit(random), unit(random), unit(random)} *
                                                  (t % 7 == 0 ? 0.5f : 0.05f));
            soup.indices.push_back(3 * t + std::uint32_t(k));
        }
    }
    scene.meshes.push_back(soup);
    for (int i = 0; i < 8; ++i)
        addQuad(scene, {-1.0 + 0.25 * i, -1, -1}, {0, 0.5, 0}, {0, 0, 0.5}, grey);  // x planes
    std::vector<std::array<Vec3f, 3>> triangles;
    for (const vox::Mesh& mesh : scene.meshes)
        for (std::size_t t = 0; t < mesh.triangleCount(); ++t)
            triangles.push_back({mesh.positions[mesh.indices[3 * t]],
                                 mesh.positions[mesh.indices[3 * t + 1]],
                                 mesh.positions[mesh.indices[3 * t + 2]]});
    std::vector<vox::Ray> rays;
    for (int i = 0; i < 2000; ++i) {
        const Vec3d o{2.0 * unit(random), 2.0 * unit(random), 2.0 * unit(random)};
        rays.push_back({o, vox::normalize(Vec3d{unit(random), unit(random), unit(random)})});
    }
    // Along the axes, from the soup's corners and in the quads' planes.
    for (int i = 0; i < 300; ++i) {
        const Vec3f c = triangles[std::size_t(i) * 7].at(std::size_t(i) % 3);
        const Vec3d o{c.x, c.y, c.z};
        const int axis = i % 3;
        Vec3d d{0, 0, 0};
        d[axis] = i % 2 ? 1.0 : -1.0;
        rays.push_back({o - d * 3.0, d});
        rays.push_back({Vec3d{-1.0 + 0.25 * (i % 8), -0.9 + 0.001 * i, -3}, Vec3d{0, 0, 1}});
    }
    std::vector<float> nearest;
    for (const vox::Ray& ray : rays) {
        const Vec3f o{float(ray.origin.x), float(ray.origin.y), float(ray.origin.z)};
        const Vec3f d{float(ray.direction.x), float(ray.direction.y), float(ray.direction.z)};
        float t = std::numeric_limits<float>::infinity();
        for (const auto& c : triangles) t = std::min(t, intersectOne(o, d, c[0], c[1], c[2]));
        nearest.push_back(t);
    }
    // Both box kernels: eight boxes at once with AVX2 (where the CPU has it), four at a time.
    const bool before = vox::detail::setTriangleCasterAvx2(true);
    for (const bool avx2 : {true, false}) {
        if (vox::detail::setTriangleCasterAvx2(avx2) != avx2) continue;  // no AVX2 here
        const vox::TriangleRayCaster caster(scene);
        int hits = 0;
        for (std::size_t i = 0; i < rays.size(); ++i) {
            const vox::SurfaceHit hit = caster.castSurface(rays[i]);
            ASSERT_EQ(hit.hit, std::isfinite(nearest[i])) << "AVX2 " << avx2 << ", ray " << i;
            if (!hit.hit) continue;
            ++hits;
            EXPECT_EQ(float(hit.t), nearest[i]);
        }
        EXPECT_GT(hits, 1000);  // 1162: the test compares hits, not only misses
    }
    vox::detail::setTriangleCasterAvx2(before);
}

}  // namespace
