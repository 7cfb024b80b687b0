/// @file final_gather.h
/// @brief A cone-traced final gather over a baked radiance volume (Gui et al. 2019, 2.4, at the
/// pixels instead of the voxels): a surface point seen by the camera is lit by the scene's static
/// punctual lights through shadow cones, by the volume's light through seven diffuse cones and by
/// one specular cone along the mirrored view direction. `voxinspect render FILE.rvol` shades with
/// it, and a GL runtime's shader is meant to compute exactly these terms (docs/cli.md).
#pragma once

#include <vox/lighting.h>
#include <vox/many_lights.h>
#include <vox/base/math.h>
#include <vox/radiance_field.h>
#include <vox/raycast.h>
#include <vox/scene.h>

#include <cstdint>
#include <functional>
#include <span>
#include <vector>

namespace vox {

class TriangleRayCaster;

/// A surface point to shade, in world units.
struct ShadingPoint {
    Vec3d position{0, 0, 0};
    Vec3d normal{0, 0, 1};    ///< unit shading normal, on the side the viewer is on
    Vec3d albedo{0, 0, 0};    ///< linear diffuse albedo
    Vec3d emission{0, 0, 0};  ///< linear emitted radiance
    Vec3d view{0, 0, 1};      ///< unit, from the point towards the viewer
};

struct FinalGatherOptions {
    /// Full apex angle of the specular cone, degrees, in (0, 90).
    double specularApertureDegrees = 10;
    /// Full apex angle of the shadow cones, degrees, in (0, 90).
    double shadowApertureDegrees = 10;
    /// false: no shadow cones, every light reaches every point facing it (visibility 1).
    bool shadowCones = true;
    /// Where every cone starts, in level-0 cells off the surface along the normal: clear of the
    /// surface's own conservative voxels (the bake's gathers start as far off).
    double offsetCells = 2;
    /// λ of the ambient-occlusion falloff (eq. 4); renderers pass the bake's (rvol BakeInfo).
    double aoLambda = 8;
    /// Reflectance at normal incidence of the specular term (Schlick): 0.04, a dielectric.
    double specularF0 = 0.04;
    /// renderFinalGather's direct light through Lightcuts (many_lights.h): the pixels' surface
    /// points are the render points, clustered by the paper's view-frustum subdivision
    /// (clusterPixelPoints), each point's cut within lightcut.relativeError of its direct light.
    LightcutsMode lightcuts = LightcutsMode::Auto;
    LightcutOptions lightcut;
    /// renderFinalGather also lights every pixel with classic Lightcuts and brute force and
    /// reports them (FinalGatherImage::directLight).
    bool lightcutsCompare = false;
};

/// The terms of one shaded point, linear radiance towards the viewer.
struct FinalGatherParts {
    Vec3d direct{0, 0, 0};    ///< Σ lights albedo/π · E · max(0, n·l) · visibility
    Vec3d indirect{0, 0, 0};  ///< albedo/π · the seven diffuse cones' irradiance
    Vec3d specular{0, 0, 0};  ///< Schlick(F0, n·v) · radiance of the cone along the mirrored view
    double ao = 1;            ///< 1 − the diffuse cones' occlusion: 1 open, 0 enclosed
    Vec3d final{0, 0, 0};     ///< emission + direct + indirect + specular
};

/// Shades surface points against one radiance volume and a set of punctual lights. Thread-safe
/// (shade() only reads); the field (and its volume) must outlive it. Shading throws what the
/// field's sampling throws (a volume read from files: IoError, InvalidDataError).
class FinalGather {
public:
    /// Lights the direct term with every light of @p lights, static and dynamic: the volume holds
    /// the static lights' bounces, and neither the bounces of dynamic lights nor anyone's direct
    /// light, so a dynamic light (a moving lamp) is lit here, frame by frame, without its
    /// bounces. @throws UsageError for an aperture outside (0, 90) degrees or a negative or
    /// non-finite offset, λ or F0.
    FinalGather(const RadianceField& field, std::span<const Light> lights,
                const FinalGatherOptions& options = {});

    /// Every term of @p point, the direct one by summing every light.
    [[nodiscard]] FinalGatherParts shade(const ShadingPoint& point) const;
    /// Every term of @p point with the direct light (radiance) given: what renderFinalGather
    /// does once Lightcuts has lit its pixels.
    [[nodiscard]] FinalGatherParts shade(const ShadingPoint& point, Vec3d direct) const;
    /// Visibility of one light from @p point (1 − the opacity a shadow cone from the offset point
    /// towards the light accumulates up to the light's distance); 1 without shadow cones.
    [[nodiscard]] double visibility(const ShadingPoint& point, const LightArrival& arrival) const;

    [[nodiscard]] const RadianceField& field() const noexcept { return field_; }
    [[nodiscard]] const FinalGatherOptions& options() const noexcept { return options_; }
    [[nodiscard]] std::size_t lightCount() const noexcept { return lights_.size(); }
    [[nodiscard]] std::size_t staticLightCount() const noexcept;
    [[nodiscard]] const std::vector<Light>& lights() const noexcept { return lights_; }

private:
    const RadianceField& field_;
    std::vector<Light> lights_;
    FinalGatherOptions options_;
    double offset_ = 0;  ///< world distance of the cones' start off the surface
    double tanHalfSpecular_ = 0, tanHalfShadow_ = 0;
};

/// The point a ray hits in a scene's static meshes (through @p caster, built over @p scene):
/// castSurface, then the material at the hit (linear albedo = base colour × texture × vertex
/// colour, emission, shading normal; textures filtered over @p footprintAngle × t), two-sided:
/// the geometric normal decides the side facing the ray and the shading normal follows it.
/// Returns false where the ray misses.
[[nodiscard]] bool sceneShadingPoint(const Scene& scene, const TriangleRayCaster& caster,
                                     const Ray& ray, double footprintAngle, ShadingPoint& out);

/// The point a ray hits in an octree (EsvoRayCaster with @p options; attributes are looked up
/// whatever options.attributes says): where the ray enters the voxel hit, its filtered colour as
/// linear albedo (0.8 grey where the voxel has none) and its shading normal (else the face
/// normal) turned towards the ray, no emission. Returns false where the ray misses.
[[nodiscard]] bool esvoShadingPoint(const EsvoRayCaster& caster, const Ray& ray,
                                    const CastOptions& options, ShadingPoint& out);

/// A final-gathered image: per pixel, row 0 at the top; zero where the primary ray missed.
struct FinalGatherImage {
    int width = 0, height = 0;
    std::vector<std::uint8_t> hit;  ///< 1 where the primary ray hit
    std::vector<Vec3f> final, direct, indirect, specular;
    std::vector<float> ao;
    std::vector<Vec3f> albedo, normal;  ///< the shading point's albedo and unit normal
    std::uint64_t hits = 0;
    double seconds = 0;        ///< wall time of hits and shading
    double directSeconds = 0;  ///< of which the direct light (FinalGatherImage::directLight)
    ManyLightReport
        directLight;  ///< how the direct light was computed (FinalGatherOptions::lightcuts)
};

/// Finds the surface a primary ray hits (false: a miss). Called concurrently.
using ShadingPointFunction = std::function<bool(const Ray& ray, ShadingPoint& out)>;

/// One primary ray per pixel through its centre (PinholeCamera::rayThrough), @p surface for the
/// hit; the direct light of all hit points through directLight (Lightcuts over view-frustum
/// clusters, or brute force, as FinalGatherOptions say); then @p gather's shade() for the other
/// terms, in parallel (TBB). Deterministic: the same inputs give the same image whatever the
/// thread count. @throws UsageError for a bad camera, and what shading throws (FinalGather).
[[nodiscard]] FinalGatherImage renderFinalGather(const FinalGather& gather,
                                                 const PinholeCamera& camera,
                                                 const ShadingPointFunction& surface);

}  // namespace vox
