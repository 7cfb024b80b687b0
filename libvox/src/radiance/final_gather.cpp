// The cone-traced final gather at surface points: direct light through shadow cones, diffuse
// cones for the indirect light and AO, one specular cone.
#include <vox/final_gather.h>

#include "../scene/surface_shading.h"

#include <vox/base/error.h>
#include <vox/formats/esvo_attributes.h>
#include <vox/texture.h>
#include <vox/triangle_raycast.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>

namespace vox {
namespace {

constexpr double kPi = 3.14159265358979323846;

double tanHalfAperture(double degrees, const char* what) {
    if (!(degrees > 0 && degrees < 90))
        throw ParameterError(what, "must be between 0 and 90 degrees (exclusive)");
    return std::tan(0.5 * degrees * kPi / 180);
}

}  // namespace

FinalGather::FinalGather(const RadianceField& field, std::span<const Light> lights,
                         const FinalGatherOptions& options)
    : field_(field), options_(options) {
    tanHalfSpecular_ = tanHalfAperture(options.specularApertureDegrees, "specularApertureDegrees");
    tanHalfShadow_ = tanHalfAperture(options.shadowApertureDegrees, "shadowApertureDegrees");
    if (!(options.offsetCells >= 0) || !std::isfinite(options.offsetCells))
        throw UsageError("final gather: the cone offset must be ≥ 0");
    if (!(options.aoLambda >= 0) || !std::isfinite(options.aoLambda))
        throw UsageError("final gather: λ must be a finite number ≥ 0");
    if (!(options.specularF0 >= 0 && options.specularF0 <= 1))
        throw UsageError("final gather: F0 must be between 0 and 1");
    lights_.assign(lights.begin(), lights.end());
    offset_ = options.offsetCells * field.finestCell();
}

double FinalGather::visibility(const ShadingPoint& point, const LightArrival& arrival) const {
    if (!options_.shadowCones) return 1;
    const Vec3d origin = point.position + point.normal * offset_;
    double maxDistance = 1e30;
    if (std::isfinite(arrival.distance)) {
        // Stop where a sample's trilinear filter (1.5 footprints each way, the footprint 2·t·tan)
        // would reach the light: the fixture or ceiling right beside a light would otherwise
        // shadow it by a part that jumps with the number of steps, drawing rings around it.
        const Vec3d light = point.position + arrival.toLight * arrival.distance;
        maxDistance = length(light - origin) / (1 + 3 * tanHalfShadow_);
    }
    // Samples stay in front of a plane one cell above the surface (as gatherDiffuse's do), so the
    // cone does not shadow the point with the surface's own voxels.
    RadianceField::Cone cone{origin,         arrival.toLight,
                             tanHalfShadow_, 0,
                             maxDistance,    point.position + point.normal * field_.finestCell(),
                             point.normal};
    return 1 - field_.traceCone(cone, 0, true).opacity;
}

std::size_t FinalGather::staticLightCount() const noexcept {
    return static_cast<std::size_t>(
        std::count_if(lights_.begin(), lights_.end(), [](const Light& l) { return !l.dynamic; }));
}

FinalGatherParts FinalGather::shade(const ShadingPoint& point) const {
    Vec3d irradiance{0, 0, 0};  // direct, after the cosine and visibility
    for (const Light& light : lights_) {
        LightArrival arrival;
        if (!lightArrival(light, point.position, arrival)) continue;
        const double cosine = dot(point.normal, arrival.toLight);
        if (!(cosine > 0)) continue;
        const double v = visibility(point, arrival);
        if (!(v > 0)) continue;
        irradiance += arrival.irradiance * (cosine * v);
    }
    return shade(point, point.albedo / kPi * irradiance);
}

FinalGatherParts FinalGather::shade(const ShadingPoint& point, Vec3d direct) const {
    FinalGatherParts out;
    const Vec3d n = point.normal;
    const Vec3d albedoOverPi = point.albedo / kPi;
    out.direct = direct;

    const RadianceField::Gather gather =
        field_.gatherDiffuse(point.position, n, offset_, options_.aoLambda);
    out.indirect = albedoOverPi * gather.irradiance;
    out.ao = std::clamp(1 - gather.occlusion, 0.0, 1.0);

    const double cosView = std::clamp(dot(n, point.view), 0.0, 1.0);
    const Vec3d reflected = normalize(n * (2 * cosView) - point.view);
    if (reflected.x != 0 || reflected.y != 0 || reflected.z != 0) {
        const double fresnel =
            options_.specularF0 + (1 - options_.specularF0) * std::pow(1 - cosView, 5.0);
        const RadianceField::Cone cone{point.position + n * offset_,
                                       reflected,
                                       tanHalfSpecular_,
                                       0,
                                       1e30,
                                       point.position + n * field_.finestCell(),
                                       n};
        out.specular = field_.traceCone(cone, options_.aoLambda).radiance * fresnel;
    }
    out.final = point.emission + out.direct + out.indirect + out.specular;
    return out;
}

bool sceneShadingPoint(const Scene& scene, const TriangleRayCaster& caster, const Ray& ray,
                       double footprintAngle, ShadingPoint& out) {
    const SurfaceHit hit = caster.castSurface(ray);
    if (!hit.hit) return false;
    const Mesh& mesh = scene.meshes[hit.mesh];
    std::array<Vec3d, 3> corners;
    for (int k = 0; k < 3; ++k) {
        const Vec3f p = mesh.positions[mesh.indices[3 * std::size_t{hit.triangle} +
                                                    static_cast<std::size_t>(k)]];
        corners[static_cast<std::size_t>(k)] = {p.x, p.y, p.z};
    }
    // From the barycentric weights in double precision: on the triangle's plane, unlike
    // origin + t·d with t rounded to float.
    out.position = corners[0] * hit.barycentric.x + corners[1] * hit.barycentric.y +
                   corners[2] * hit.barycentric.z;
    const detail::SurfaceSample s = detail::shadeTriangle(scene, {hit.mesh, hit.triangle}, corners,
                                                          hit.barycentric, footprintAngle * hit.t);
    // Two-sided: the geometric normal decides the side, the shading normal follows it.
    const Vec3d side =
        dot(hit.geometricNormal, ray.direction) < 0 ? hit.geometricNormal : -hit.geometricNormal;
    out.normal = dot(s.normal, side) < 0 ? -s.normal : s.normal;
    out.albedo = {s.color.x, s.color.y, s.color.z};
    out.emission = {s.emission.x, s.emission.y, s.emission.z};
    out.view = -ray.direction;
    return true;
}

bool esvoShadingPoint(const EsvoRayCaster& caster, const Ray& ray, const CastOptions& options,
                      ShadingPoint& out) {
    CastOptions withAttributes = options;
    withAttributes.attributes = true;
    const CastHit hit = caster.cast(ray, withAttributes);
    if (!hit.hit) return false;
    out.position = ray.origin + ray.direction * double(hit.t);
    Vec3d side{hit.normal.x, hit.normal.y, hit.normal.z};
    if (dot(side, ray.direction) > 0) side = -side;
    const bool attributes =
        hit.hasAttributes &&
        (hit.shadingNormal.x != 0 || hit.shadingNormal.y != 0 || hit.shadingNormal.z != 0);
    Vec3d n =
        attributes ? Vec3d{hit.shadingNormal.x, hit.shadingNormal.y, hit.shadingNormal.z} : side;
    if (dot(n, side) < 0) n = -n;
    out.normal = normalize(n);
    if (attributes) {
        out.albedo = {srgbToLinear(float(esvo::colorChannel(hit.color, 0)) / 255.0f),
                      srgbToLinear(float(esvo::colorChannel(hit.color, 1)) / 255.0f),
                      srgbToLinear(float(esvo::colorChannel(hit.color, 2)) / 255.0f)};
    } else {
        out.albedo = {0.8, 0.8, 0.8};
    }
    out.emission = {0, 0, 0};
    out.view = -ray.direction;
    return true;
}

FinalGatherImage renderFinalGather(const FinalGather& gather, const PinholeCamera& camera,
                                   const ShadingPointFunction& surface) {
    camera.validate();
    FinalGatherImage image;
    image.width = camera.width;
    image.height = camera.height;
    const std::size_t pixels = std::size_t(camera.width) * std::size_t(camera.height);
    image.hit.assign(pixels, 0);
    image.final.assign(pixels, Vec3f{0, 0, 0});
    image.direct.assign(pixels, Vec3f{0, 0, 0});
    image.indirect.assign(pixels, Vec3f{0, 0, 0});
    image.specular.assign(pixels, Vec3f{0, 0, 0});
    image.ao.assign(pixels, 0.0f);
    image.albedo.assign(pixels, Vec3f{0, 0, 0});
    image.normal.assign(pixels, Vec3f{0, 0, 0});
    const auto start = std::chrono::steady_clock::now();
    std::vector<ShadingPoint> points(pixels);
    tbb::parallel_for(tbb::blocked_range<int>(0, camera.height),
                      [&](const tbb::blocked_range<int>& rows) {
                          for (int y = rows.begin(); y != rows.end(); ++y)
                              for (int x = 0; x < camera.width; ++x) {
                                  const std::size_t i =
                                      std::size_t(y) * std::size_t(camera.width) + std::size_t(x);
                                  if (surface(camera.rayThrough(x, y), points[i])) image.hit[i] = 1;
                              }
                      });

    // Direct light at every hit point: the render points of Lightcuts.
    std::vector<std::size_t> hitPixels;
    for (std::size_t i = 0; i < pixels; ++i)
        if (image.hit[i]) hitPixels.push_back(i);
    std::vector<LightcutPoint> renderPoints(hitPixels.size());
    for (std::size_t k = 0; k < hitPixels.size(); ++k) {
        const ShadingPoint& p = points[hitPixels[k]];
        renderPoints[k] = LightcutPoint::lambertian(p.position, p.normal, p.albedo);
    }
    const auto directStart = std::chrono::steady_clock::now();
    const auto clusters = [&] {
        std::vector<std::array<std::uint32_t, 2>> where(hitPixels.size());
        std::vector<double> depths(hitPixels.size());
        const Vec3d forward = normalize(camera.target - camera.eye);
        for (std::size_t k = 0; k < hitPixels.size(); ++k) {
            where[k] = {std::uint32_t(hitPixels[k] % std::size_t(camera.width)),
                        std::uint32_t(hitPixels[k] / std::size_t(camera.width))};
            depths[k] = dot(renderPoints[k].position - camera.eye, forward);
        }
        return clusterPixelPoints(renderPoints, where, depths, camera);
    };
    const PointVisibility visibility = [&](std::size_t k, const Light&,
                                           const LightArrival& arrival) {
        return gather.visibility(points[hitPixels[k]], arrival);
    };
    std::vector<Vec3d> direct(hitPixels.size());
    const FinalGatherOptions& options = gather.options();
    // Dynamic lights are lit here like static ones (directLight would leave them out, as a bake
    // must).
    std::vector<Light> lights = gather.lights();
    for (Light& light : lights) light.dynamic = false;
    image.directLight = directLight(lights, renderPoints, options.lightcuts, options.lightcut,
                                    options.lightcutsCompare, clusters, visibility, direct);
    image.directSeconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - directStart).count();

    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, hitPixels.size(), 256),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                          for (std::size_t k = r.begin(); k != r.end(); ++k) {
                              const std::size_t i = hitPixels[k];
                              const ShadingPoint& point = points[i];
                              const FinalGatherParts parts = gather.shade(point, direct[k]);
                              image.final[i] = vec3Cast<float>(parts.final);
                              image.direct[i] = vec3Cast<float>(parts.direct);
                              image.indirect[i] = vec3Cast<float>(parts.indirect);
                              image.specular[i] = vec3Cast<float>(parts.specular);
                              image.ao[i] = static_cast<float>(parts.ao);
                              image.albedo[i] = vec3Cast<float>(point.albedo);
                              image.normal[i] = vec3Cast<float>(point.normal);
                          }
                      });
    image.hits = hitPixels.size();
    image.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return image;
}

}  // namespace vox
