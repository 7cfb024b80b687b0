/// @file path_reference.h
/// @brief A Monte Carlo path-traced reference for the radiance bake's diffuse irradiance, shared by
/// its test (tests/test_path_reference.cpp) and the accuracy benchmark (bench/radiance_accuracy),
/// so the bake is measured against the estimator the tests prove correct.
///
/// Transport model (what the bake approximates, stated so the two can be compared):
/// - every surface is Lambertian with albedo ρ = the linear base colour (alpha ignored: opaque)
///   and two-sided: at a hit, the side facing the arriving ray is the surface's front, and the
///   shading normal is flipped to that side;
/// - emissive surfaces emit their material emission as radiance Le, from both sides;
/// - punctual lights deliver vox::lightArrival's irradiance, times max(0, n·l), times a shadow ray;
/// - dynamic meshes and dynamic lights are absent (a static bake).
///
/// For a surface point x with unit normal n, per linear RGB channel:
/// - E_direct(x) = Σ_lights E_light(x) · max(0, n·l) · V(x, light), computed exactly (no sampling);
/// - E1(x) = ∫_H L1(y) cos θ dω, with L1(y) = Le(y) + ρ(y)/π · E_direct(y) and y the first surface
///   seen from x along ω: the light after exactly one diffuse reflection or one emission;
/// - E2(x) = ∫_H ρ(y)/π · E1(y) cos θ dω: after exactly two reflections (or one of emission).
///
/// Estimators, with cosine-weighted directions (pdf cos θ / π) so the cosine and π cancel: one
/// path x → y → z per sample gives π·L1(y) for E1 and ρ(y)·π·L1(z) for E2 (z seen from y over the
/// hemisphere of y's shading normal: an unbiased one-sample estimate of ρ(y)·E1(y)). Both are
/// averages of independent samples, so their standard errors are the samples' standard deviation
/// over √N.
#pragma once

#include <vox/base/math.h>
#include <vox/scene.h>
#include <vox/triangle_raycast.h>

#include <cstdint>
#include <span>
#include <vector>

namespace vox::reference {

/// Luminance of a linear RGB colour with sRGB / Rec. 709 primaries (the scenes' colour space).
[[nodiscard]] double luminance(Vec3d rgb);
/// A unit direction about unit @p n with density cos θ / π for (@p u1, @p u2) uniform in
/// [0, 1)² (Malley: a disc point lifted onto the hemisphere), in the orthonormal frame of Duff et
/// al. 2017.
[[nodiscard]] Vec3d cosineDirection(Vec3d n, double u1, double u2);

/// A point on a surface where irradiance is wanted.
struct SurfacePoint {
    Vec3d position{0, 0, 0};
    /// Unit normal of the side to gather on: the hemisphere it points into is integrated, and rays
    /// leave from position offset along it (so for curved or normal-mapped surfaces pass a normal
    /// whose side the geometry agrees with).
    Vec3d normal{0, 0, 1};
};

/// A Monte Carlo estimate of an irradiance.
struct IrradianceEstimate {
    Vec3d mean{0, 0, 0};           ///< per linear RGB channel
    Vec3d standardError{0, 0, 0};  ///< of the mean, per channel: sample standard deviation / √N
    double luminance = 0;          ///< luminance(mean)
    /// Standard error of luminance, from the samples' own luminances (so the channels'
    /// correlation is accounted for, not bounded).
    double luminanceStandardError = 0;
    std::uint64_t samples = 0;
    /// luminanceStandardError / luminance; 0 where both are 0 (a dark point is known exactly),
    /// +inf where only the luminance is 0.
    [[nodiscard]] double relativeStandardError() const;
};

/// The reference at one point.
struct PointIrradiance {
    Vec3d direct{0, 0, 0};       ///< E_direct: exact, from the punctual lights with shadow rays
    IrradianceEstimate bounce1;  ///< E1
    IrradianceEstimate bounce2;  ///< E2
};

struct PathReferenceOptions {
    std::uint32_t samples = 4096;  ///< paths per point (each gives one E1 and one E2 sample)
    std::uint64_t seed = 1;        ///< with the point's index, seeds every point's random streams
};

/// The reference estimator over one scene. Thread-safe; results depend only on the points,
/// options and scene, not on the thread count (each point's samples are drawn in fixed chunks
/// from streams seeded by (seed, point, chunk) and summed in chunk order).
class PathReference {
public:
    /// Builds the BVH over @p scene's static triangles. @p scene must outlive the reference.
    explicit PathReference(const Scene& scene);

    /// Distance rays leave surfaces at, along the normal of the side they leave: 1e-5 of the
    /// scene's largest absolute coordinate, about a hundred float ulps of the single-precision
    /// intersection, and far below any gap a scene models (a 2 m Cornell box: 0.02 mm).
    [[nodiscard]] double rayOffset() const noexcept { return offset_; }

    /// E_direct at @p point (exact: every punctual light with a shadow ray).
    [[nodiscard]] Vec3d directIrradiance(const SurfacePoint& point) const;

    /// E_direct, E1 and E2 at each of @p points, in parallel (TBB).
    [[nodiscard]] std::vector<PointIrradiance> estimate(std::span<const SurfacePoint> points,
                                                        const PathReferenceOptions& options) const;

private:
    struct Vertex;
    /// The surface @p ray hits, shaded and turned towards the ray; false where it escapes.
    [[nodiscard]] bool intersect(const Ray& ray, Vertex& out) const;
    /// E_direct at @p position with shading normal @p normal, shadow rays leaving from
    /// @p position offset along @p side (the geometric normal of the side lit).
    [[nodiscard]] Vec3d direct(Vec3d position, Vec3d normal, Vec3d side) const;
    /// L1 leaving @p vertex: Le + ρ/π · E_direct.
    [[nodiscard]] Vec3d onceScattered(const Vertex& vertex) const;

    const Scene& scene_;
    TriangleRayCaster caster_;
    std::vector<const Light*> lights_;  ///< the static ones
    double offset_ = 0;
};

}  // namespace vox::reference
