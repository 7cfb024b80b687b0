// The radiance bake (Gui et al. 2019 as an offline bake): voxelize with the octree's voxelizer,
// light level 0 directly, filter the anisotropic mips, then gather bounces with cones and
// re-filter after each.
#include "air_regions.h"
#include "radiance_mips.h"
#include "ray_gather.h"
#include "scene_occupancy.h"
#include "voxel_shadows.h"

#include <vox/base/error.h>
#include <vox/octree.h>
#include <vox/radiance.h>
#include <vox/radiance_field.h>
#include <vox/util/progress.h>

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

namespace vox {

namespace {

constexpr double kPi = 3.14159265358979323846;
/// Where the cones of a gather start, in level-0 cells off the surface: clear of the surface's own
/// conservative voxels (up to two thick where a plane runs along a cell boundary); starting further
/// out loses contact light in corners and skips thin occluders. Chosen against the path-traced
/// reference (bench/radiance_accuracy).
constexpr double kGatherOffsetCells = 2;
/// A voxel shows no light to a cone looking along an axis direction when under this share of its
/// surface on that axis faces the cone (it is the back of a surface there).
constexpr float kHiddenShare = 0.1f;
/// Most voxels in one spatial cluster of the direct light's Lightcuts: small enough that a
/// cluster's list skips the trees far from it, large enough for cut reuse to pay.
constexpr std::uint32_t kClusterVoxels = 512;

/// Per level-0 voxel: the bits of the channels that see only the back of its surface.
std::uint8_t hiddenChannels(const VoxelNormals& normals) {
    std::uint8_t bits = 0;
    for (std::uint32_t k = 0; k < rvol::kDirections; ++k) {
        const std::uint32_t axis = k / 2;
        const bool looksNegative = k & 1u;
        // A cone looking along +axis sees the faces whose normals point along −axis.
        const float front = normals.moments[2 * axis + (looksNegative ? 0 : 1)];
        const float back = normals.moments[2 * axis + (looksNegative ? 1 : 0)];
        if (front + back > 0.05f && front < kHiddenShare * (front + back))
            bits = static_cast<std::uint8_t>(bits | (1u << k));
    }
    return bits;
}

Vec3d toVec3d(Vec3f v) { return {v.x, v.y, v.z}; }

/// A volume a set of voxels gathers bounce light from: level 0 holds its members, the mips are
/// filtered from them.
struct GatherVolume {
    rvol::Volume* volume = nullptr;
    rvol::Volume own;                    ///< storage, for the volumes of air regions
    std::vector<std::size_t> members;    ///< leaf indices, ascending (Morton order)
    std::vector<std::size_t> cellTexel;  ///< per member: its texel in level 0
    std::vector<std::uint8_t> hidden;    ///< per level-0 texel (filterMips)
    std::unique_ptr<RadianceField> field;

    void build(rvol::Volume& target, const std::vector<LeafMaterial>& leaves,
               std::vector<std::size_t> memberIndices) {
        volume = &target;
        members = std::move(memberIndices);
        std::vector<std::array<std::uint32_t, 3>> cells(members.size());
        for (std::size_t k = 0; k < members.size(); ++k)
            cells[k] = {leaves[members[k]].x, leaves[members[k]].y, leaves[members[k]].z};
        detail::allocateVolume(target, cells, cellTexel);
        hidden.assign(target.levels[0].texels.size(), 0);
        for (std::size_t k = 0; k < members.size(); ++k) {
            target.levels[0].texels[cellTexel[k]].a = 1;
            hidden[cellTexel[k]] = hiddenChannels(leaves[members[k]].normals);
        }
        field = std::make_unique<RadianceField>(target);
    }
    /// Level 0 from per-leaf radiance, then the mips.
    void update(const std::vector<Vec3f>& radiance) {
        auto& texels = volume->levels[0].texels;
        for (std::size_t k = 0; k < members.size(); ++k) {
            const Vec3f& L = radiance[members[k]];
            rvol::Texel& t = texels[cellTexel[k]];
            t.r = L.x;
            t.g = L.y;
            t.b = L.z;
        }
        detail::filterMips(*volume, *field, hidden);
    }
};

}  // namespace

RadianceBake bakeRadiance(const Scene& scene, const RadianceBakeOptions& options) {
    if (options.depth < 1 || options.depth > 10)
        throw ParameterError("radianceDepth", "must be between 1 and 10");
    if (options.bounces > 16) throw ParameterError("bounces", "must be at most 16");
    if (!(options.shadowApertureDegrees >= 0 && options.shadowApertureDegrees < 90))
        throw ParameterError("shadowApertureDegrees", "must be at least 0 and below 90 degrees");
    if (!(options.aoLambda >= 0) || !std::isfinite(options.aoLambda))
        throw ParameterError("aoLambda", "must be a finite number ≥ 0");
    // With rays: the strata per axis of the rays' pattern.
    const auto gatherStrata =
        static_cast<std::uint32_t>(std::lround(std::sqrt(options.gatherRays)));
    if (options.bounceGather == BounceGather::Rays || options.bounceGather == BounceGather::Auto) {
        if (options.gatherRays < 1 || options.gatherRays > 4096 ||
            gatherStrata * gatherStrata != options.gatherRays)
            throw ParameterError("gatherRays", "must be a square number from 1 to 4096");
        if (options.region && options.bounceGather == BounceGather::Rays)
            throw ParameterError("bounceGather", "rays are not available for tiled bakes");
    } else if (options.bounceGather != BounceGather::Cones) {
        throw ParameterError("bounceGather", "must be cones, rays or auto");
    }

    RadianceBake bake;
    rvol::Volume& volume = bake.volume;
    const Bounds3f bounds = scene.bounds();
    const RadianceBakeRegion* tile = options.region;
    const RootCube cube =
        tile ? RootCube{tile->cubeOrigin, tile->cubeSize} : RootCube::enclosing(bounds);
    volume.origin = {cube.origin.x, cube.origin.y, cube.origin.z};
    volume.size = cube.size;
    volume.depth = options.depth;
    volume.sceneBounds = {bounds.min.x, bounds.min.y, bounds.min.z,
                          bounds.max.x, bounds.max.y, bounds.max.z};

    // Conservative voxelization with the octree's voxelizer: a cell is solid where a triangle
    // touches its closed cube; its material is the area-weighted mean over its fragments.
    SurfaceVoxelizeOptions voxelize;
    voxelize.depth = options.depth;
    voxelize.cube = &cube;
    voxelize.leafMaterials = true;
    voxelize.timings = options.timings;
    std::vector<LeafMaterial> leaves = voxelizeSurface(scene, voxelize).leafMaterials;
    std::vector<LeafMaterial> dynamicLeaves;
    if (scene.dynamicTriangleCount() > 0) {
        voxelize.onlyDynamic = true;
        dynamicLeaves = voxelizeSurface(scene, voxelize).leafMaterials;
    }
    if (tile) {
        // A tile: only the cells of the kept box (its own region and the halo) take part.
        const auto outside = [tile](const LeafMaterial& v) {
            return v.x < tile->keepLo[0] || v.y < tile->keepLo[1] || v.z < tile->keepLo[2] ||
                   v.x >= tile->keepHi[0] || v.y >= tile->keepHi[1] || v.z >= tile->keepHi[2];
        };
        std::erase_if(leaves, outside);
        std::erase_if(dynamicLeaves, outside);
        if (leaves.empty()) {  // nothing to light: an empty volume over the owned cube
            rvol::Volume own;
            own.origin = {tile->ownOrigin.x, tile->ownOrigin.y, tile->ownOrigin.z};
            own.size = tile->ownSize;
            own.depth = tile->ownDepth;
            own.sceneBounds = volume.sceneBounds;
            std::vector<std::size_t> none;
            detail::allocateVolume(own, {}, none);
            bake.volume = std::move(own);
            return bake;
        }
    }
    bake.staticVoxels = leaves.size();
    bake.dynamicVoxels = dynamicLeaves.size();

    std::vector<std::array<std::uint32_t, 3>> cells(leaves.size());
    for (std::size_t i = 0; i < leaves.size(); ++i)
        cells[i] = {leaves[i].x, leaves[i].y, leaves[i].z};
    const detail::SolidGrid solid(options.depth, cells);
    const double cell = volume.cellSize(0);
    const auto centreOf = [&](const LeafMaterial& v) {
        return Vec3d{volume.origin[0] + (v.x + 0.5) * cell, volume.origin[1] + (v.y + 0.5) * cell,
                     volume.origin[2] + (v.z + 0.5) * cell};
    };

    // Empty space, split into its connected regions. Where it splits into large regions (closed
    // rooms; the outside), each gets a volume of the voxels touching it, and the voxels facing it
    // gather from that one: nothing behind a wall reaches them, however coarse a cone's samples.
    GatherVolume all;  // every static voxel: the volume that is stored
    std::vector<std::unique_ptr<GatherVolume>> regionVolumes;
    std::vector<std::int32_t> gatherFrom(leaves.size(), -1);  // index into regionVolumes, -1: all
    {
        Timings::Scope timer(options.timings, "radiance_regions");
        // A tile's cube reaches beyond the root cube, where the whole bake has no air.
        std::array<std::int64_t, 3> rootLo{}, rootHi{};
        rootHi.fill(detail::AirRegions::kNoLimit);
        if (tile && tile->occupancy)
            for (std::size_t a = 0; a < 3; ++a) {
                rootLo[a] = -tile->cubeCell[a];
                rootHi[a] = (std::int64_t{1} << tile->rootDepth) - tile->cubeCell[a];
            }
        const detail::AirRegions regions(solid, options.depth, rootLo, rootHi);
        std::vector<std::uint16_t> faced(leaves.size());
        std::vector<std::uint64_t> facedCount(regions.count(), 0);
        for (std::size_t i = 0; i < leaves.size(); ++i) {
            faced[i] =
                regions.facing(leaves[i].x, leaves[i].y, leaves[i].z, leaves[i].normals.mean);
            if (faced[i] < regions.count()) ++facedCount[faced[i]];
        }
        {
            std::vector<std::size_t> everyone(leaves.size());
            for (std::size_t i = 0; i < leaves.size(); ++i) everyone[i] = i;
            all.build(volume, leaves, std::move(everyone));
        }
        // Regions faced by at least 1 % of the voxels, largest first (at most 8), unless one
        // region is faced by nearly every voxel (then the whole volume is its volume).
        std::vector<std::uint16_t> chosen;
        for (std::uint32_t r = 0; r < regions.count(); ++r)
            if (facedCount[r] * 100 >= leaves.size())
                chosen.push_back(static_cast<std::uint16_t>(r));
        std::stable_sort(chosen.begin(), chosen.end(), [&](std::uint16_t a, std::uint16_t b) {
            return facedCount[a] > facedCount[b];
        });
        if (chosen.size() > 8) chosen.resize(8);
        if (!chosen.empty() && facedCount[chosen.front()] * 100 < 99 * leaves.size())
            for (std::uint16_t region : chosen) {
                std::vector<std::size_t> members;
                for (std::size_t i = 0; i < leaves.size(); ++i)
                    if (regions.touches(leaves[i].x, leaves[i].y, leaves[i].z, region))
                        members.push_back(i);
                auto gv = std::make_unique<GatherVolume>();
                gv->own.origin = volume.origin;
                gv->own.size = volume.size;
                gv->own.depth = volume.depth;
                gv->build(gv->own, leaves, std::move(members));
                const auto index = static_cast<std::int32_t>(regionVolumes.size());
                for (std::size_t i = 0; i < leaves.size(); ++i)
                    if (faced[i] == region) gatherFrom[i] = index;
                regionVolumes.push_back(std::move(gv));
            }
    }
    // A tile's cones continue beyond its kept box through the far field; its shadow rays through
    // the whole scene's occupancy at this level's resolution (the far field's coarse, thickened
    // cells shadowed a fifth of the direct light wrongly).
    std::unique_ptr<RadianceField> farField;
    if (tile && tile->far) {
        farField = std::make_unique<RadianceField>(*tile->far);
        const Vec3d nearLo{volume.origin[0] + tile->keepLo[0] * cell,
                           volume.origin[1] + tile->keepLo[1] * cell,
                           volume.origin[2] + tile->keepLo[2] * cell};
        const Vec3d nearHi{volume.origin[0] + tile->keepHi[0] * cell,
                           volume.origin[1] + tile->keepHi[1] * cell,
                           volume.origin[2] + tile->keepHi[2] * cell};
        all.field->setFarField(farField.get(), nearLo, nearHi);
        for (auto& gv : regionVolumes) gv->field->setFarField(farField.get(), nearLo, nearHi);
    }
    // Whether a shadow ray (level-0 cell units) is blocked after leaving the kept box, where the
    // tile's own grid holds no voxels.
    const auto farOccluded = [&](Vec3d local, Vec3d dir, double maxT) {
        if (!tile || !tile->occupancy) return false;
        double exit = maxT;  // where the ray leaves the kept box
        for (int a = 0; a < 3; ++a) {
            if (dir[a] > 0) exit = std::min(exit, (tile->keepHi[a] - local[a]) / dir[a]);
            if (dir[a] < 0) exit = std::min(exit, (tile->keepLo[a] - local[a]) / dir[a]);
        }
        exit = std::max(exit, 0.0);
        if (exit >= maxT) return false;
        const Vec3d world{local.x + double(tile->cubeCell[0]), local.y + double(tile->cubeCell[1]),
                          local.z + double(tile->cubeCell[2])};
        const std::array<std::int64_t, 3> start{static_cast<std::int64_t>(std::floor(world.x)),
                                                static_cast<std::int64_t>(std::floor(world.y)),
                                                static_cast<std::int64_t>(std::floor(world.z))};
        return tile->occupancy->occluded(world, dir, exit, maxT, start);
    };
    const RadianceField& field = *all.field;
    // Auto gathers by rays where the volume is whole and its voxels' hits are kept (traced once).
    const bool gatherByRays =
        options.bounces > 0 && (options.bounceGather == BounceGather::Rays ||
                                (options.bounceGather == BounceGather::Auto && !tile &&
                                 detail::RayGather::keepsHits(leaves.size(), options.gatherRays)));

    const auto staticLights = std::count_if(scene.lights.begin(), scene.lights.end(),
                                            [](const Light& l) { return !l.dynamic; });
    volume.bake = {options.bounces,
                   static_cast<float>(options.shadowApertureDegrees),
                   static_cast<float>(options.aoLambda),
                   static_cast<std::uint32_t>(options.attenuation),
                   static_cast<std::uint32_t>(staticLights),
                   gatherByRays ? options.gatherRays : 0};

    // Shadow cones need the occlusion of the mips before any light is in them.
    const bool shadowCones = options.shadowApertureDegrees > 0;
    if (shadowCones) {
        Timings::Scope timer(options.timings, "radiance_occlusion_mips");
        detail::filterMips(volume, field, all.hidden);
    }

    // Direct light (eq. 2 attenuation, shadow rays or cones), through Lightcuts when there are
    // many lights. The render points' albedo is π so that their "radiance" is the irradiance the
    // bounces need too; the cut's error is then relative to the irradiance.
    const double tanHalf = std::tan(0.5 * options.shadowApertureDegrees * kPi / 180);
    // How much of the light arriving at leaf i along @p arrival reaches it (shadow rays through
    // the solid cells, or a shadow cone).
    const auto leafVisibility = [&](std::size_t i, const LightArrival& arrival) -> double {
        const LeafMaterial& v = leaves[i];
        const Vec3d n = toVec3d(v.normals.mean);
        // Leave the voxel on the side of its surface that faces the light.
        const double side = dot(n, arrival.toLight) >= 0 ? 1.0 : -1.0;
        if (shadowCones) {
            const Vec3d origin = centreOf(v) + n * (side * kGatherOffsetCells * cell);
            return 1 -
                   field.traceCone({origin, arrival.toLight, tanHalf, 0, arrival.distance}, 0, true)
                       .opacity;
        }
        const Vec3d local{v.x + 0.5 + side * n.x, v.y + 0.5 + side * n.y, v.z + 0.5 + side * n.z};
        const double maxT = std::isfinite(arrival.distance) ? arrival.distance / cell : 1e30;
        return solid.occluded(local, arrival.toLight, maxT) ||
                       farOccluded(local, arrival.toLight, maxT)
                   ? 0.0
                   : 1.0;
    };
    std::vector<Vec3f> direct(leaves.size());
    {
        Timings::Scope timer(options.timings, "radiance_direct");
        std::vector<LightcutPoint> points(leaves.size());
        tbb::parallel_for(std::size_t{0}, leaves.size(), [&](std::size_t i) {
            points[i] = LightcutPoint::voxel(centreOf(leaves[i]), leaves[i].normals,
                                             options.attenuation, {kPi, kPi, kPi});
        });
        const PointVisibility visibility = [&](std::size_t i, const Light&,
                                               const LightArrival& arrival) {
            return leafVisibility(i, arrival);
        };
        // Clusters for the cluster–light lists and cut reuse: octree nodes of similar voxels (the
        // same material, normals within 10°), at most kClusterVoxels each.
        const auto clusters = [&] {
            std::vector<LightcutPoint> materials(points);
            for (std::size_t i = 0; i < leaves.size(); ++i)
                materials[i].albedo = toVec3d(leaves[i].albedo);
            return clusterVoxelPoints(materials, cells, options.depth, kClusterVoxels);
        };
        // Lightcuts' shadow rays, decided a block of voxels at a time where one test proves the
        // whole block's rays to a light clear or blocked (exactly the rays' answers, see
        // ShadowRayGroups); classic Lightcuts and brute force trace every ray.
        // Built when Lightcuts first asks, so that its time counts in Lightcuts' own.
        std::optional<detail::ShadowRayGroups> rayGroups;
        std::once_flag groupsBuilt;
        const auto buildGroups = [&] {
            std::vector<Vec3f> normals(leaves.size());
            for (std::size_t i = 0; i < leaves.size(); ++i) normals[i] = leaves[i].normals.mean;
            std::vector<Vec3d> lightCells(scene.lights.size());
            for (std::size_t k = 0; k < scene.lights.size(); ++k) {
                const Light& light = scene.lights[k];
                const double nan = std::numeric_limits<double>::quiet_NaN();
                lightCells[k] = light.type == Light::Type::Directional
                                    ? Vec3d{nan, nan, nan}
                                    : Vec3d{(double(light.position.x) - volume.origin[0]) / cell,
                                            (double(light.position.y) - volume.origin[1]) / cell,
                                            (double(light.position.z) - volume.origin[2]) / cell};
            }
            rayGroups.emplace(solid, cells, std::move(normals), std::move(lightCells));
        };
        ClusterVisibilityFactory sharedRays;
        if (!shadowCones && options.shareShadowRays && !tile) {
            sharedRays = [&](std::span<const std::uint32_t> members,
                             SharedVisibilityStats& stats) -> ClusterVisibility {
                // Isolated: waiting for its own parallel work, the building thread must not pick
                // up another cluster's task, which would wait for the groups in turn.
                std::call_once(groupsBuilt, [&] { tbb::this_task_arena::isolate(buildGroups); });
                auto verdicts =
                    std::make_shared<detail::ShadowRayGroups::Verdicts>(*rayGroups, members);
                return [&, verdicts](std::size_t i, std::uint32_t index, const Light&,
                                     const LightArrival& arrival) -> double {
                    const int side =
                        dot(toVec3d(leaves[i].normals.mean), arrival.toLight) >= 0 ? 1 : -1;
                    const double maxT =
                        std::isfinite(arrival.distance) ? arrival.distance / cell : 1e30;
                    return rayGroups->occluded(i, index, side, arrival.toLight, maxT, *verdicts,
                                               stats)
                               ? 0.0
                               : 1.0;
                };
            };
        }
        std::vector<Vec3d> irradiance(leaves.size());
        bake.directLight =
            directLight(scene.lights, points, options.lightcuts, options.lightcut,
                        options.lightcutsCompare, clusters, visibility, irradiance, sharedRays);
        for (std::size_t i = 0; i < leaves.size(); ++i)
            direct[i] = {static_cast<float>(irradiance[i].x), static_cast<float>(irradiance[i].y),
                         static_cast<float>(irradiance[i].z)};
    }

    // Bounces gathered by rays: trace them once. A voxel that rays reach on both sides (a thin
    // part: a triangle facing away from its mean normal) has each side lit apart for them, as a
    // plane about the normal the rays saw there, and gathered apart, instead of reading the
    // radiance of its normals' mix on both (a sunlit wall's inside is dark).
    std::optional<detail::RayGather> rays;
    std::vector<detail::RayGather::TwoSidedLeaf> twoSided;  // ascending by leaf
    std::vector<std::array<Vec3f, 2>> sideDirect;  // per two-sided leaf: front, back irradiance
    if (gatherByRays) {
        {
            Timings::Scope timer(options.timings, "radiance_ray_gather_setup");
            rays.emplace(scene, leaves, Vec3d{volume.origin[0], volume.origin[1], volume.origin[2]},
                         cell, options.depth, gatherStrata);
        }
        {
            Timings::Scope timer(options.timings, "radiance_ray_trace");
            Progress progress("bounce rays", leaves.size());
            twoSided = rays->trace(&progress);
            bake.twoSidedVoxels = twoSided.size();
        }
        Timings::Scope timer(options.timings, "radiance_direct_sides");
        sideDirect.resize(twoSided.size());
        const PointVisibility visibility = [&](std::size_t k, const Light&,
                                               const LightArrival& arrival) {
            return leafVisibility(twoSided[k].leaf, arrival);
        };
        for (const int side : {0, 1}) {
            // A plain cosine about the normal the rays saw on the side: the moments mix both
            // sides.
            std::vector<LightcutPoint> points(twoSided.size());
            for (std::size_t k = 0; k < twoSided.size(); ++k) {
                const auto& t = twoSided[k];
                points[k] = LightcutPoint::lambertian(
                    centreOf(leaves[t.leaf]), side == 0 ? t.front : t.back, {kPi, kPi, kPi});
            }
            std::vector<Vec3d> irradiance(points.size());
            (void)directLight(scene.lights, points, options.lightcuts, options.lightcut, false, {},
                              visibility, irradiance);
            for (std::size_t k = 0; k < points.size(); ++k)
                sideDirect[k][std::size_t(side)] = vec3Cast<float>(irradiance[k]);
        }
    }

    // Level 0's radiance from the irradiance a voxel receives: emission + albedo/π · E.
    std::vector<Vec3f> radiance(leaves.size());
    const auto leave = [&](const LeafMaterial& v, Vec3f e) -> Vec3f {
        const float k = static_cast<float>(1 / kPi);
        return {v.emission.x + v.albedo.x * k * e.x, v.emission.y + v.albedo.y * k * e.y,
                v.emission.z + v.albedo.z * k * e.z};
    };
    // What the rays read on a voxel's front and back side: its radiance, but at the two-sided
    // voxels each side's own.
    std::vector<Vec3f> rayFront, rayBack(twoSided.empty() ? 0 : leaves.size());
    std::vector<Vec3f> backGathered(twoSided.size());  // per two-sided leaf: its back's bounce
    const auto light = [&](const std::vector<Vec3f>* gathered) {
        tbb::parallel_for(std::size_t{0}, leaves.size(), [&](std::size_t i) {
            Vec3f e = direct[i];
            if (gathered) e = e + (*gathered)[i];
            radiance[i] = leave(leaves[i], e);
        });
        all.update(radiance);
        for (auto& gv : regionVolumes) gv->update(radiance);
        if (!rays) return;
        rayFront = radiance;
        tbb::parallel_for(std::size_t{0}, twoSided.size(), [&](std::size_t k) {
            const std::uint32_t i = twoSided[k].leaf;
            // Each side adds the bounce it gathered: the voxel's own gather about its mean normal
            // on the front, the back's own rays on the back.
            const Vec3f front = gathered ? (*gathered)[i] : Vec3f{0, 0, 0};
            const Vec3f back = gathered ? backGathered[k] : Vec3f{0, 0, 0};
            rayFront[i] = leave(leaves[i], sideDirect[k][0] + front);
            rayBack[i] = leave(leaves[i], sideDirect[k][1] + back);
        });
    };
    {
        Timings::Scope timer(options.timings, "radiance_filter");
        light(nullptr);
    }

    // Bounces: gather over the volume lit so far, light level 0 again, re-filter.
    std::vector<Vec3f> gathered(leaves.size()), previous(leaves.size());
    std::vector<float> occlusion(leaves.size(), 0);
    if (options.keepVoxelLighting) bake.voxels.resize(leaves.size());
    const std::uint32_t passes =
        std::max<std::uint32_t>(options.bounces, 1);  // one pass for AO without bounces
    for (std::uint32_t b = 0; b < passes; ++b) {
        Timings::Scope timer(options.timings, "radiance_bounce_" + std::to_string(b + 1));
        // Cones: the irradiance and (first pass) the ambient occlusion; with rays, the cones'
        // occlusion alone (first pass) and the irradiance from the rays.
        const std::uint64_t units = leaves.size() * (rays && b == 0 ? 2 : 1);
        Progress progress("bounce " + std::to_string(b + 1), units);
        if (!rays || b == 0)
            tbb::parallel_for(
                tbb::blocked_range<std::size_t>(0, leaves.size(), 512),
                [&](const tbb::blocked_range<std::size_t>& r) {
                    for (std::size_t i = r.begin(); i != r.end(); ++i) {
                        const LeafMaterial& v = leaves[i];
                        const RadianceField& from =
                            gatherFrom[i] < 0
                                ? field
                                : *regionVolumes[static_cast<std::size_t>(gatherFrom[i])]->field;
                        const auto g =
                            from.gatherDiffuse(centreOf(v), toVec3d(v.normals.mean),
                                               kGatherOffsetCells * cell, options.aoLambda);
                        gathered[i] = {static_cast<float>(g.irradiance.x),
                                       static_cast<float>(g.irradiance.y),
                                       static_cast<float>(g.irradiance.z)};
                        if (b == 0) occlusion[i] = static_cast<float>(g.occlusion);
                    }
                    progress.advance(r.size());
                });
        if (rays && b < options.bounces) {
            detail::RayGather::Irradiance g = rays->gather(rayFront, rayBack, &progress);
            gathered = std::move(g.leaves);
            backGathered = std::move(g.backs);
        }
        if (options.keepVoxelLighting && b < options.bounces)
            for (std::size_t i = 0; i < leaves.size(); ++i)
                bake.voxels[i].indirect.push_back(gathered[i] - previous[i]);
        previous = gathered;
        if (b < options.bounces) light(&gathered);
    }

    if (options.keepVoxelLighting)
        for (std::size_t i = 0; i < leaves.size(); ++i) {
            VoxelLighting& out = bake.voxels[i];
            const LeafMaterial& v = leaves[i];
            out.x = v.x;
            out.y = v.y;
            out.z = v.z;
            out.centre = centreOf(v);
            out.normal = v.normals.mean;
            out.albedo = v.albedo;
            out.emission = v.emission;
            out.direct = direct[i];
        }

    const auto attributes = [](const LeafMaterial& v, float ao) {
        rvol::VoxelAttributes a;
        a.x = v.x;
        a.y = v.y;
        a.z = v.z;
        a.albedo = {v.albedo.x, v.albedo.y, v.albedo.z};
        a.coverage = v.coverage;
        a.normal = {v.normals.mean.x, v.normals.mean.y, v.normals.mean.z};
        a.emission = {v.emission.x, v.emission.y, v.emission.z};
        a.occlusion = ao;
        return a;
    };
    if (tile) {
        // Store the owned cube alone, its level 0 from the owned voxels, its mips filtered anew.
        const auto& lo = tile->ownLo;
        const std::uint32_t n = 1u << tile->ownDepth;
        const auto owned = [&](const LeafMaterial& v) {
            return v.x >= lo[0] && v.y >= lo[1] && v.z >= lo[2] && v.x - lo[0] < n &&
                   v.y - lo[1] < n && v.z - lo[2] < n;
        };
        const auto local = [&](LeafMaterial v) {
            v.x -= lo[0];
            v.y -= lo[1];
            v.z -= lo[2];
            return v;
        };
        rvol::Volume own;
        own.origin = {tile->ownOrigin.x, tile->ownOrigin.y, tile->ownOrigin.z};
        own.size = tile->ownSize;
        own.depth = tile->ownDepth;
        own.sceneBounds = volume.sceneBounds;
        own.bake = volume.bake;
        std::vector<LeafMaterial> ownLeaves;
        std::vector<Vec3f> ownRadiance;
        // The owned cube need not be aligned to its own size in the bake's cube: re-sort the
        // voxels into Morton order of their owned-cube cells.
        const auto mortonOrder = [&](const std::vector<LeafMaterial>& from) {
            std::vector<std::pair<std::uint64_t, std::size_t>> order;
            for (std::size_t i = 0; i < from.size(); ++i)
                if (owned(from[i])) {
                    const LeafMaterial v = local(from[i]);
                    order.emplace_back(rvol::morton3(v.x, v.y, v.z), i);
                }
            std::sort(order.begin(), order.end());
            return order;
        };
        for (const auto& [code, i] : mortonOrder(leaves)) {
            ownLeaves.push_back(local(leaves[i]));
            ownRadiance.push_back(radiance[i]);
            own.staticVoxels.push_back(attributes(ownLeaves.back(), occlusion[i]));
        }
        for (const auto& [code, i] : mortonOrder(dynamicLeaves))
            own.dynamicVoxels.push_back(attributes(local(dynamicLeaves[i]), 0));
        {
            GatherVolume stored;
            std::vector<std::size_t> everyone(ownLeaves.size());
            for (std::size_t i = 0; i < ownLeaves.size(); ++i) everyone[i] = i;
            stored.build(own, ownLeaves, std::move(everyone));
            stored.update(ownRadiance);
        }
        bake.staticVoxels = own.staticVoxels.size();
        bake.dynamicVoxels = own.dynamicVoxels.size();
        regionVolumes.clear();
        all.field.reset();
        bake.volume = std::move(own);
        return bake;
    }
    volume.staticVoxels.reserve(leaves.size());
    for (std::size_t i = 0; i < leaves.size(); ++i)
        volume.staticVoxels.push_back(attributes(leaves[i], occlusion[i]));
    volume.dynamicVoxels.reserve(dynamicLeaves.size());
    for (const LeafMaterial& v : dynamicLeaves) volume.dynamicVoxels.push_back(attributes(v, 0));
    return bake;
}

}  // namespace vox
