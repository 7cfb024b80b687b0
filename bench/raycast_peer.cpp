// Ray casting against its peer: renders a mesh and its .esvo from the same cameras, the mesh with
// the BVH triangle caster and the octree with the ESVO caster, in the same process, and prints
// JSON with both speeds, their ratio, and how well the two images agree (hit/miss, depth within
// one leaf-voxel diagonal along the ray, and along the surface normal). Where the .esvo has colours
// and normals, a further (untimed) render compares them with the mesh's material at the same
// pixels: colour PSNR (8-bit sRGB) and the angle between the voxel's normal and the mesh's
// interpolated shading normal, as stored and after the post-process filter.
// Where CMake found Embree 3 (libembree-dev), Embree's single rays (rtcIntersect1, BVH built at
// RTC_BUILD_QUALITY_HIGH, build not timed) cast the same pixels too: "embree" gives its Mrays/s,
// hit fraction and hit/miss agreement with the BVH caster, "octree_over_embree" the speed ratio.
// With several views (--view repeated), every figure is over the pixels of all of them together
// and the seconds are summed; "views" lists each view's own figures.
// Usage: raycast_peer MESH ESVO (--eye x,y,z --target x,y,z [--up x,y,z] | --view dx,dy,dz [--view
// ...])
//                    [--fov D] [--width W] [--height H] [--repeat N] [--threads N] [--embree-only]
//                    [--distance S]
// --view frames the mesh's bounds from direction (dx,dy,dz): the bounding sphere just fits the
// image height, or with --distance S the eye is S times as far (S < 1: closer, more rays hit);
// each view's "eye", "target" and "up"
// are in the JSON, to the last bit (voxinspect render --eye/--target/--up then casts the same
// rays).
// --threads: TBB threads for every caster (default: all cores). --embree-only: cast only Embree
// (ESVO is not read): bench/raycast_table.sh's peer run beside voxinspect render.
// --bounce-rays K (ESVO is not read): the rays a bounce gather casts, K from each pixel's
// primary hit on the mesh, cast by the BVH triangle caster and by Embree: "bounce_rays".
#include <vox/base/error.h>
#include <vox/formats/esvo_attributes.h>
#include <vox/import.h>
#include <vox/util/log.h>
#include <vox/util/parallel.h>
#include <vox/raycast.h>
#include <vox/texture.h>
#include <vox/triangle_raycast.h>

#include <nlohmann/json.hpp>

#include "embree_peer.h"  // no Embree headers: its .cpp is built only with LIBVOX_HAVE_EMBREE

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

namespace {

constexpr double kDegrees = 180.0 / 3.14159265358979323846;

vox::Vec3d parse(const char* text) {
    vox::Vec3d v;
    if (std::sscanf(text, "%lf,%lf,%lf", &v.x, &v.y, &v.z) != 3)
        throw vox::UsageError(std::string("expected x,y,z: ") + text);
    return v;
}

/// Best of @p repeat renders (the machine is shared and noisy).
template <typename Render>
vox::RenderBuffers best(int repeat, Render render) {
    vox::RenderBuffers result = render();
    for (int i = 1; i < repeat; ++i) {
        vox::RenderBuffers again = render();
        if (again.seconds < result.seconds) result = std::move(again);
    }
    return result;
}

/// Sums and samples over the pixels of one or more views.
struct Comparison {
    double rays = 0, meshSeconds = 0, octreeSeconds = 0, lodSeconds = 0;
    std::uint64_t agree = 0, bothHit = 0, within = 0, infront = 0, surfaceWithin = 0;
    std::vector<double> depthErrors;
    // Attributes (files with colours and normals).
    bool attributes = false;
    std::vector<double> angles, sameSurfaceAngles, filteredAngles;
    double squared = 0, sameSurfaceSquared = 0, filteredSquared = 0, lodSquared = 0;
    std::uint64_t compared = 0, sameSurface = 0, lodCompared = 0;
    double radiusSum = 0, hits = 0;
    // Embree (where built with it).
    bool embree = false;
    double embreeSeconds = 0;
    std::uint64_t embreeHits = 0, embreeAgree = 0;

    void add(const Comparison& o) {
        rays += o.rays, meshSeconds += o.meshSeconds, octreeSeconds += o.octreeSeconds,
            lodSeconds += o.lodSeconds;
        agree += o.agree, bothHit += o.bothHit, within += o.within, infront += o.infront,
            surfaceWithin += o.surfaceWithin;
        depthErrors.insert(depthErrors.end(), o.depthErrors.begin(), o.depthErrors.end());
        attributes = attributes || o.attributes;
        angles.insert(angles.end(), o.angles.begin(), o.angles.end());
        sameSurfaceAngles.insert(sameSurfaceAngles.end(), o.sameSurfaceAngles.begin(),
                                 o.sameSurfaceAngles.end());
        filteredAngles.insert(filteredAngles.end(), o.filteredAngles.begin(),
                              o.filteredAngles.end());
        squared += o.squared, sameSurfaceSquared += o.sameSurfaceSquared,
            filteredSquared += o.filteredSquared, lodSquared += o.lodSquared;
        compared += o.compared, sameSurface += o.sameSurface, lodCompared += o.lodCompared;
        radiusSum += o.radiusSum, hits += o.hits;
        embree = embree || o.embree;
        embreeSeconds += o.embreeSeconds, embreeHits += o.embreeHits, embreeAgree += o.embreeAgree;
    }
};

#ifdef LIBVOX_HAVE_EMBREE
/// Embree's best of @p repeat casts from @p camera; hit/miss agreement against @p bvhDepth
/// (the BVH caster's depths) where given.
void castEmbree(const bench::EmbreePeer& embree, const vox::PinholeCamera& camera, int repeat,
                const std::vector<float>* bvhDepth, Comparison& c) {
    bench::EmbreeImage image = embree.render(camera);
    for (int i = 1; i < repeat; ++i) {
        bench::EmbreeImage again = embree.render(camera);
        if (again.seconds < image.seconds) image = std::move(again);
    }
    c.embree = true;
    c.rays = double(image.depth.size());
    c.embreeSeconds = image.seconds;
    c.embreeHits = image.hits;
    if (bvhDepth)
        for (std::size_t i = 0; i < image.depth.size(); ++i)
            c.embreeAgree += std::isfinite(image.depth[i]) == std::isfinite((*bvhDepth)[i]);
}
#endif

#ifdef LIBVOX_HAVE_EMBREE
/// Bounce rays cast by both triangle casters, summed over views.
struct BounceComparison {
    double rays = 0, oursSeconds = 0, embreeSeconds = 0;
    std::uint64_t oursHits = 0, embreeHits = 0, agree = 0, sameDepth = 0;
    void add(const BounceComparison& o) {
        rays += o.rays, oursSeconds += o.oursSeconds, embreeSeconds += o.embreeSeconds;
        oursHits += o.oursHits, embreeHits += o.embreeHits, agree += o.agree,
            sameDepth += o.sameDepth;
    }
};

/// The rays a bounce gather casts: from each pixel's primary hit on the mesh (the BVH caster's,
/// untimed), @p perHit directions cosine-distributed about the triangle's normal turned to the
/// camera (the strata of a square pattern, turned about the normal by a fixed per-pixel angle),
/// starting 1e-5 of the mesh's bounding radius off the surface; each caster's best of
/// @p repeat.
BounceComparison compareBounceRays(const vox::TriangleRayCaster& triangles,
                                   const bench::EmbreePeer& embree,
                                   const vox::PinholeCamera& camera, int perHit, double radius,
                                   int repeat) {
    const int strata = std::max(1, static_cast<int>(std::lround(std::sqrt(double(perHit)))));
    std::vector<float> origins, directions;
    std::vector<vox::Ray> rays;
    for (int y = 0; y < camera.height; ++y)
        for (int x = 0; x < camera.width; ++x) {
            const vox::Ray primary = camera.rayThrough(x, y);
            const vox::SurfaceHit h = triangles.castSurface(primary);
            if (!h.hit) continue;
            vox::Vec3d n = h.geometricNormal;
            if (vox::dot(n, primary.direction) > 0) n = n * -1.0;
            const vox::Vec3d from = primary.origin + primary.direction * h.t + n * (1e-5 * radius);
            const vox::OrthonormalFrame frame(n);
            const double turn = 2 * 3.14159265358979323846 *
                                double((std::uint32_t(y * camera.width + x) * 2654435761u) >> 8) /
                                double(1 << 24);
            for (int k = 0; k < perHit; ++k) {
                const double u = (double(k % strata) + 0.5) / strata;
                const double v = (double(k / strata % strata) + 0.5) / strata;
                const double r = std::sqrt(u), phi = 2 * 3.14159265358979323846 * v + turn;
                const vox::Vec3d d = frame.toWorld(r * std::cos(phi), r * std::sin(phi),
                                                   std::sqrt(std::max(0.0, 1.0 - u)));
                rays.push_back({from, d});
                for (int a = 0; a < 3; ++a)
                    origins.push_back(float(from[a])), directions.push_back(float(d[a]));
            }
        }
    BounceComparison c;
    c.rays = double(rays.size());
    std::vector<float> ours(rays.size());
    for (int i = 0; i < repeat; ++i) {
        std::atomic<std::uint64_t> hits{0};
        const auto start = std::chrono::steady_clock::now();
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, rays.size(), 256),
                          [&](const tbb::blocked_range<std::size_t>& r) {
                              std::uint64_t chunkHits = 0;
                              for (std::size_t j = r.begin(); j != r.end(); ++j) {
                                  const vox::SurfaceHit h = triangles.castSurface(rays[j]);
                                  ours[j] =
                                      h.hit ? float(h.t) : std::numeric_limits<float>::infinity();
                                  chunkHits += h.hit ? 1 : 0;
                              }
                              hits += chunkHits;
                          });
        const double seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        if (i == 0 || seconds < c.oursSeconds) c.oursSeconds = seconds;
        c.oursHits = hits;
    }
    bench::EmbreeImage image = embree.cast(origins, directions);
    for (int i = 1; i < repeat; ++i) {
        bench::EmbreeImage again = embree.cast(origins, directions);
        if (again.seconds < image.seconds) image = std::move(again);
    }
    c.embreeSeconds = image.seconds;
    c.embreeHits = image.hits;
    for (std::size_t j = 0; j < rays.size(); ++j) {
        const bool a = std::isfinite(ours[j]), b = std::isfinite(image.depth[j]);
        c.agree += a == b;
        c.sameDepth += a && b && std::abs(ours[j] - image.depth[j]) <= 1e-4f * float(radius);
    }
    return c;
}

nlohmann::json bounceReport(const BounceComparison& c) {
    const double oursRate = c.rays / c.oursSeconds / 1e6,
                 embreeRate = c.rays / c.embreeSeconds / 1e6;
    return {{"rays", c.rays},
            {"mrays_per_second", oursRate},
            {"hit_fraction", double(c.oursHits) / c.rays},
            {"embree_mrays_per_second", embreeRate},
            {"embree_hit_fraction", double(c.embreeHits) / c.rays},
            {"ours_over_embree", oursRate / embreeRate},
            {"hit_agreement", double(c.agree) / c.rays},
            {"same_depth", double(c.sameDepth) / c.rays}};
}
#endif

/// Renders the mesh and the octree from @p camera and compares them.
Comparison compareView(const vox::TriangleRayCaster& triangles, const vox::EsvoRayCaster& octree,
                       bool withAttributes, const vox::PinholeCamera& camera, int repeat,
                       [[maybe_unused]] const bench::EmbreePeer* embree) {
    Comparison c;
    vox::CastOptions leaves;  // no LOD: the geometry comparison is against the leaves
    vox::CastOptions lod;
    lod.lodAngle = camera.pixelAngle();
    const auto mesh = best(repeat, [&] { return vox::renderTriangles(triangles, camera); });
    const auto full = best(repeat, [&] { return vox::renderEsvo(octree, camera, leaves); });
    const auto cut = best(repeat, [&] { return vox::renderEsvo(octree, camera, lod); });
    c.rays = double(mesh.depth.size());
    c.meshSeconds = mesh.seconds, c.octreeSeconds = full.seconds, c.lodSeconds = cut.seconds;
#ifdef LIBVOX_HAVE_EMBREE
    if (embree) castEmbree(*embree, camera, repeat, &mesh.depth, c);
#endif

    const double diagonal = std::sqrt(3.0) * octree.leafVoxelSize();
    // |cos| between pixel i's ray and the mesh normal there: a distance along the ray times it is
    // the distance along the normal, which grazing rays do not inflate.
    const auto normalCosine = [&](std::size_t i) {
        const vox::Ray ray = camera.rayThrough(static_cast<int>(i % std::size_t(camera.width)),
                                               static_cast<int>(i / std::size_t(camera.width)));
        const vox::Vec3f n = mesh.normal[i];
        return std::abs(n.x * ray.direction.x + n.y * ray.direction.y + n.z * ray.direction.z);
    };
    for (std::size_t i = 0; i < mesh.depth.size(); ++i) {
        const bool a = std::isfinite(mesh.depth[i]), b = std::isfinite(full.depth[i]);
        c.agree += a == b;
        if (!(a && b)) continue;
        ++c.bothHit;
        const double e = double(full.depth[i]) - double(mesh.depth[i]);
        c.depthErrors.push_back(std::abs(e) / diagonal);
        c.within += std::abs(e) <= diagonal;
        c.infront += e <= 1e-6;
        c.surfaceWithin += std::abs(e) * normalCosine(i) <= diagonal;
    }
    if (!withAttributes) return c;

    c.attributes = true;
    vox::CastOptions attributeOptions;
    attributeOptions.attributes = true;
    const auto shaded = vox::renderEsvo(octree, camera, attributeOptions);
    // Squared 8-bit sRGB error of a colour word against the mesh's at pixel i.
    const auto squaredError = [&](std::uint32_t color, std::size_t i) {
        double sq = 0;
        for (unsigned ch = 0; ch < 3; ++ch) {
            const double d = double(vox::esvo::colorChannel(color, ch)) -
                             double(vox::esvo::colorChannel(mesh.color[i], ch));
            sq += d * d;
        }
        return sq;
    };
    const auto compares = [&](const vox::RenderBuffers& image, std::size_t i) {
        return std::isfinite(mesh.depth[i]) && std::isfinite(image.depth[i]) &&
               vox::hasAttributes(image, i);
    };
    const auto angle = [](vox::Vec3f a, vox::Vec3f b) {
        return std::acos(std::clamp(double(dot(a, b)), -1.0, 1.0)) * kDegrees;
    };
    // The post-process filter (voxinspect render --filter), on the colours and on the normals
    // (renormalised): what a viewer of the filtered image sees.
    const std::vector<float> radius = vox::filterRadii(shaded, octree, camera);
    const std::vector<vox::Vec3f> filteredColor =
        vox::postProcessFilter(vox::albedoImage(shaded), radius, camera.width, camera.height);
    const std::vector<vox::Vec3f> filteredNormal =
        vox::postProcessFilter(shaded.shadingNormal, radius, camera.width, camera.height);
    for (std::size_t i = 0; i < mesh.depth.size(); ++i) {
        if (!compares(shaded, i)) continue;
        const double a = angle(shaded.shadingNormal[i], mesh.shadingNormal[i]);
        const double sq = squaredError(shaded.color[i], i);
        c.angles.push_back(a);
        c.squared += sq;
        ++c.compared;
        // The same surface: the hit points lie within a leaf diagonal of each other along the
        // normal (not a voxel that also holds a neighbouring surface).
        if (std::abs(double(shaded.depth[i]) - double(mesh.depth[i])) * normalCosine(i) <=
            diagonal) {
            c.sameSurfaceAngles.push_back(a);
            c.sameSurfaceSquared += sq;
            ++c.sameSurface;
        }
        const vox::Vec3f fn = filteredNormal[i];
        const float fl = std::sqrt(dot(fn, fn));
        c.filteredAngles.push_back(fl > 0 ? angle(fn * (1.0f / fl), mesh.shadingNormal[i]) : a);
        const auto byte = [&](int ch) {
            return static_cast<std::uint32_t>(std::lround(
                255.0 * vox::linearToSrgb(std::clamp(filteredColor[i][ch], 0.0f, 1.0f))));
        };
        c.filteredSquared += squaredError(vox::esvo::packColor(byte(0), byte(1), byte(2)), i);
    }
    // With the level-of-detail cut (a voxel no smaller than the pixel): coarser voxels' colours
    // are their own filtered means, so this is the octree's anti-aliased image.
    vox::CastOptions lodAttributes = attributeOptions;
    lodAttributes.lodAngle = camera.pixelAngle();
    const auto lodShaded = vox::renderEsvo(octree, camera, lodAttributes);
    for (std::size_t i = 0; i < mesh.depth.size(); ++i) {
        if (!compares(lodShaded, i)) continue;
        c.lodSquared += squaredError(lodShaded.color[i], i);
        ++c.lodCompared;
    }
    for (float r : radius) c.radiusSum += r;
    c.hits = double(shaded.hits);
    return c;
}

nlohmann::json summary(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    double sum = 0;
    for (double x : v) sum += x;
    const auto at = [&](std::size_t percent) {
        return v.empty() ? 0.0 : v[v.size() * percent / 100];
    };
    return {{"mean", v.empty() ? 0.0 : sum / double(v.size())},
            {"p50", at(50)},
            {"p95", at(95)},
            {"p99", at(99)}};
}

double psnr(double squared, std::uint64_t n) {
    return n == 0 || squared == 0
               ? 99.0
               : 10.0 * std::log10(255.0 * 255.0 / (squared / (3.0 * double(n))));
}

/// Embree's figures, or null where it did not cast.
nlohmann::json embreeReport(const Comparison& c, bool withBvh) {
    if (!c.embree) return nullptr;
    nlohmann::json out{{"mrays_per_second", c.rays / c.embreeSeconds / 1e6},
                       {"hit_fraction", double(c.embreeHits) / c.rays}};
    if (withBvh) out["hit_miss_agreement_with_bvh"] = double(c.embreeAgree) / c.rays;
    return out;
}

/// The comparison's figures (depth errors in leaf-voxel diagonals).
nlohmann::json report(const Comparison& c) {
    const double bothHit = double(c.bothHit);
    const nlohmann::json depth = summary(c.depthErrors);
    nlohmann::json out{{"triangle_mrays_per_second", c.rays / c.meshSeconds / 1e6},
                       {"octree_mrays_per_second", c.rays / c.octreeSeconds / 1e6},
                       {"octree_lod_mrays_per_second", c.rays / c.lodSeconds / 1e6},
                       {"octree_over_triangle", c.meshSeconds / c.octreeSeconds},
                       {"octree_lod_over_triangle", c.meshSeconds / c.lodSeconds},
                       {"hit_miss_agreement", c.agree / c.rays},
                       {"both_hit_pixels", c.bothHit},
                       {"depth_within_leaf_diagonal", c.bothHit ? double(c.within) / bothHit : 0.0},
                       {"surface_distance_within_leaf_diagonal",
                        c.bothHit ? double(c.surfaceWithin) / bothHit : 0.0},
                       {"octree_not_behind_mesh", c.bothHit ? double(c.infront) / bothHit : 0.0},
                       {"depth_error_diagonals", depth},
                       {"embree", embreeReport(c, true)}};
    if (c.embree) {
        out["octree_over_embree"] = c.embreeSeconds / c.octreeSeconds;
        out["octree_lod_over_embree"] = c.embreeSeconds / c.lodSeconds;
    }
    if (!c.attributes) {
        out["attributes"] = nullptr;
        return out;
    }
    out["attributes"] = {{"compared_pixels", c.compared},
                         {"same_surface_pixels", c.sameSurface},
                         {"normal_error_degrees", summary(c.angles)},
                         {"normal_error_degrees_same_surface", summary(c.sameSurfaceAngles)},
                         {"normal_error_degrees_filtered", summary(c.filteredAngles)},
                         {"color_psnr_db", psnr(c.squared, c.compared)},
                         {"color_psnr_db_same_surface", psnr(c.sameSurfaceSquared, c.sameSurface)},
                         {"color_psnr_db_filtered", psnr(c.filteredSquared, c.compared)},
                         {"color_psnr_db_lod", psnr(c.lodSquared, c.lodCompared)},
                         {"mean_voxel_pixels", 2 * c.radiusSum / std::max(1.0, c.hits)}};
    return out;
}

}  // namespace

int main(int argc, char** argv) {
    try {
        if (argc < 3)
            throw vox::UsageError(
                "usage: raycast_peer MESH ESVO (--eye x,y,z --target x,y,z [--up x,y,z] | --view "
                "dx,dy,dz [--view ...]) "
                "[--fov D] [--width W] [--height H] [--repeat N] [--threads N] [--embree-only] "
                "[--bounce-rays K]");
        vox::PinholeCamera camera;
        camera.width = 1024;
        camera.height = 768;
        int repeat = 3, threadCount = 0, bounceRays = 0;
        double distanceScale = 1;
        bool embreeOnly = false;
        std::vector<vox::Vec3d> views;
        for (int i = 3; i < argc; i += 2) {
            const std::string key = argv[i];
            if (key == "--embree-only") {
                embreeOnly = true;
                --i;  // a flag: no value
                continue;
            }
            if (i + 1 >= argc) throw vox::UsageError(key + " needs a value");
            if (key == "--eye")
                camera.eye = parse(argv[i + 1]);
            else if (key == "--target")
                camera.target = parse(argv[i + 1]);
            else if (key == "--up")
                camera.up = parse(argv[i + 1]);
            else if (key == "--fov")
                camera.fovYDegrees = std::stod(argv[i + 1]);
            else if (key == "--width")
                camera.width = std::stoi(argv[i + 1]);
            else if (key == "--height")
                camera.height = std::stoi(argv[i + 1]);
            else if (key == "--repeat")
                repeat = std::max(1, std::stoi(argv[i + 1]));
            else if (key == "--view")
                views.push_back(parse(argv[i + 1]));
            else if (key == "--threads")
                threadCount = std::max(0, std::stoi(argv[i + 1]));
            else if (key == "--distance")
                distanceScale = std::stod(argv[i + 1]);
            else if (key == "--bounce-rays")
                bounceRays = std::stoi(argv[i + 1]);
            else
                throw vox::UsageError("unknown option " + key);
        }
#ifndef LIBVOX_HAVE_EMBREE
        if (embreeOnly || bounceRays > 0)
            throw vox::UsageError(
                "--embree-only, --bounce-rays: built without Embree (install "
                "libembree-dev and reconfigure)");
#endif
        if (bounceRays < 0 || bounceRays > 4096)
            throw vox::UsageError("--bounce-rays must be from 1 to 4096");
        const vox::ThreadLimit threads(threadCount);
        vox::log::setVerbosity(vox::log::Verbosity::Quiet);  // the benchmark's output is its JSON
        const vox::Scene scene = vox::importScene(argv[1]);
        std::vector<vox::PinholeCamera> cameras;
        if (views.empty()) cameras.push_back(camera);
        const vox::Bounds3f b = scene.bounds();
        const vox::Vec3d centre{(b.min.x + b.max.x) / 2.0, (b.min.y + b.max.y) / 2.0,
                                (b.min.z + b.max.z) / 2.0};
        const vox::Vec3f e = b.extent();
        const double radius =
            0.5 * std::sqrt(double(e.x) * e.x + double(e.y) * e.y + double(e.z) * e.z);
        for (const vox::Vec3d& view : views) {
            vox::PinholeCamera framed = camera;
            framed.target = centre;
            framed.eye =
                centre + vox::normalize(view) * (distanceScale * radius /
                                                 std::sin(0.5 * camera.fovYDegrees / kDegrees));
            // A view straight along the up vector takes another up.
            if (std::abs(vox::normalize(view).y) > 0.99) framed.up = {0, 0, 1};
            cameras.push_back(framed);
        }
        if (!(distanceScale > 0)) throw vox::UsageError("--distance must be > 0");
        for (const auto& c : cameras) c.validate();
        const auto cameraJson = [](const vox::PinholeCamera& c, nlohmann::json& r) {
            r["eye"] = {c.eye.x, c.eye.y, c.eye.z};
            r["target"] = {c.target.x, c.target.y, c.target.z};
            r["up"] = {c.up.x, c.up.y, c.up.z};
        };
        std::unique_ptr<bench::EmbreePeer> embree;
        nlohmann::json embreeBuild = nullptr;
#ifdef LIBVOX_HAVE_EMBREE
        embree = std::make_unique<bench::EmbreePeer>(scene, threadCount);
        embreeBuild = {{"version", bench::EmbreePeer::version()},
                       {"build_quality", bench::EmbreePeer::buildQuality()},
                       {"build_seconds", embree->buildSeconds()},
                       {"triangles", embree->triangleCount()},
                       {"api", "rtcIntersect1, 16x16 pixel tiles (TBB)"}};
        // What every JSON of a run starts with.
        const auto runJson = [&] {
            return nlohmann::json{{"mesh", argv[1]},
                                  {"width", camera.width},
                                  {"height", camera.height},
                                  {"fov", camera.fovYDegrees},
                                  {"threads", vox::ThreadLimit::active()},
                                  {"embree_build", embreeBuild}};
        };
        if (bounceRays > 0) {
            const vox::TriangleRayCaster triangles(scene);
            nlohmann::json perView = nlohmann::json::array();
            BounceComparison all;
            for (const auto& c : cameras) {
                const BounceComparison one =
                    compareBounceRays(triangles, *embree, c, bounceRays, radius, repeat);
                nlohmann::json r = bounceReport(one);
                cameraJson(c, r);
                perView.push_back(std::move(r));
                all.add(one);
            }
            nlohmann::json out = runJson();
            out.update({{"triangles", triangles.triangleCount()},
                        {"bounce_rays", bounceReport(all)},
                        {"views", perView}});
            std::cout << out.dump(2) << "\n";
            return 0;
        }
        if (embreeOnly) {
            Comparison all;
            nlohmann::json perView = nlohmann::json::array();
            for (const auto& c : cameras) {
                Comparison one;
                castEmbree(*embree, c, repeat, nullptr, one);
                nlohmann::json r{{"embree", embreeReport(one, false)}};
                cameraJson(c, r);
                perView.push_back(std::move(r));
                all.add(one);
            }
            nlohmann::json out = runJson();
            out.update({{"embree", embreeReport(all, false)}, {"views", perView}});
            std::cout << out.dump(2) << "\n";
            return 0;
        }
#endif
        const vox::TriangleRayCaster triangles(scene);
        const vox::esvo::EsvoReader reader(argv[2]);
        vox::esvo::EsvoPool pool(reader);
        pool.loadAll();
        const vox::EsvoRayCaster octree(pool);

        Comparison all;
        nlohmann::json perView = nlohmann::json::array();
        for (const auto& c : cameras) {
            const Comparison one = compareView(triangles, octree, reader.header().hasAttributes(),
                                               c, repeat, embree.get());
            nlohmann::json r = report(one);
            cameraJson(c, r);
            perView.push_back(std::move(r));
            all.add(one);
        }
        nlohmann::json out = report(all);
        std::uint64_t voxels = 0;
        for (std::uint64_t v : reader.directory().voxelsPerLevel) voxels += v;
        out.update({{"mesh", argv[1]},
                    {"esvo", argv[2]},
                    {"width", camera.width},
                    {"height", camera.height},
                    {"fov", camera.fovYDegrees},
                    {"threads", vox::ThreadLimit::active()},
                    {"embree_build", embreeBuild},
                    {"triangles", triangles.triangleCount()},
                    {"leaf_depth", reader.header().leafDepth},
                    {"leaf_diagonal", std::sqrt(3.0) * octree.leafVoxelSize()},
                    {"voxels", voxels},
                    {"file_bytes", reader.header().fileBytes},
                    {"attribute_kinds", reader.header().attachmentKinds},
                    {"views", perView}});
        std::cout << out.dump(2) << "\n";
        return 0;
    } catch (const vox::Error& e) {
        std::fprintf(stderr, "raycast_peer: error: %s\n", e.what());
        return static_cast<int>(e.exitCode());
    } catch (const std::exception& e) {
        std::fprintf(stderr, "raycast_peer: error: %s\n", e.what());
        return 1;
    }
}
