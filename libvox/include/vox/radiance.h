/// @file radiance.h
/// @brief The radiance bake (Gui et al. 2019, "Global illumination based on voxel cone tracing",
/// as an offline bake): conservative voxelization into albedo/normal/emission (the same
/// voxelizer as the octree), direct light from punctual lights attenuated by the voxels' normals
/// and voxel shadow rays or shadow cones, a six-direction anisotropic mip chain, cone-traced
/// diffuse bounces and ambient occlusion. The result is an rvol::Volume (docs/rvol-format.md).
#pragma once

#include <vox/formats/rvol.h>
#include <vox/lighting.h>
#include <vox/many_lights.h>
#include <vox/base/math.h>
#include <vox/scene.h>
#include <vox/util/timings.h>

#include <array>
#include <cstdint>
#include <vector>

namespace vox {

class SceneOccupancy;

/// One region of a larger volume, for a tiled bake (radiance_tiles.h): the bake runs in @p cube,
/// lights and gathers only the cells of the kept box, and stores only those of the owned cube.
struct RadianceBakeRegion {
    Vec3d cubeOrigin{0, 0, 0};  ///< the bake's root cube (2^depth cells), instead of the scene's
    double cubeSize = 1;
    std::array<std::uint32_t, 3> keepLo{}, keepHi{};  ///< cells of the cube kept: [lo, hi)
    /// The stored volume: 2^ownDepth cells per axis from cell ownLo of the cube, at ownOrigin
    /// (world) with edge ownSize; it must lie inside the kept box.
    std::array<std::uint32_t, 3> ownLo{};
    std::uint32_t ownDepth = 1;
    Vec3d ownOrigin{0, 0, 0};
    double ownSize = 1;
    /// The whole root cube baked coarser (its finest cell 2^k times the cube's): cones that leave
    /// the kept box continue through it. Null: nothing beyond the kept box.
    const rvol::Volume* far = nullptr;
    /// The whole scene's static occupancy at the finest level, in the leaf units of the root cube
    /// (2^rootDepth cells per axis) of which this cube's cell 0 is cell @p cubeCell: shadow rays
    /// that leave the kept box continue through it, and the air regions end at that root cube's
    /// faces (the kept box must lie inside it). Null: shadow rays end at the kept box.
    const SceneOccupancy* occupancy = nullptr;
    std::array<std::int64_t, 3> cubeCell{};
    std::uint32_t rootDepth = 0;
};

/// How the bake gathers each bounce's light at a voxel.
enum class BounceGather : std::uint32_t {
    /// The diffuse cones through the volume's mips (RadianceField::gatherDiffuse), as the
    /// runtime's final gather does: fast; light can leak through walls thinner than a cone's
    /// footprint, and open scenes read the edge of the volume's cube.
    Cones = 0,
    /// Stratified cosine-distributed rays against the scene's triangles from a point of the
    /// voxel's own surface, each reading the radiance the level-0 voxel at its hit leaves on the
    /// side it hits (a voxel holding both sides of a thin part has each side lit and gathered
    /// apart); the cones still give the ambient occlusion. Not for tiled bakes
    /// (RadianceBakeRegion).
    Rays = 1,
    /// Rays where the volume is baked whole and the hits of its voxels' rays fit in the memory
    /// the gather keeps them in (512 MiB: about 800 000 voxels at 256 rays), so that they are
    /// traced once; cones otherwise (tiles, larger volumes). Volume::bake.gatherRays tells which.
    Auto = 2,
};

/// Options for bakeRadiance.
struct RadianceBakeOptions {
    std::uint32_t depth = 8;  ///< level 0 has 2^depth cells along the longest side (1 … 10)
    Attenuation attenuation = Attenuation::Adaptive;
    double shadowApertureDegrees = 0;  ///< 0: shadow rays through solid voxels; > 0: shadow cones
    std::uint32_t bounces = 2;
    /// λ of the ambient-occlusion falloff (eq. 4): δ += (1 − δ)·α / (1 + λ·r), r the cone radius
    /// in units of the root cube's edge.
    double aoLambda = 8;
    BounceGather bounceGather = BounceGather::Auto;
    /// Where rays gather (BounceGather::Rays, or Auto choosing them): rays per voxel and bounce, a
    /// square number (strata²), 1 … 4096.
    std::uint32_t gatherRays = 256;
    /// Keep per-voxel irradiance per bounce in RadianceBake::voxels (tests and the accuracy bench).
    bool keepVoxelLighting = false;
    /// Direct light through Lightcuts (many_lights.h): the voxels are the render points,
    /// clustered by an octree subdivision of the volume (clusterVoxelPoints), each voxel's cut
    /// within lightcut.relativeError of its irradiance under the cut's criterion.
    LightcutsMode lightcuts = LightcutsMode::Auto;
    LightcutOptions lightcut;
    /// Also light every voxel with classic Lightcuts and brute force, for
    /// RadianceBake::directLight's comparison (the bake keeps the method lightcuts chose).
    bool lightcutsCompare = false;
    /// With shadow rays (shadowApertureDegrees 0), Lightcuts decides a light's rays for a block of
    /// nearby voxels with one test where that test proves them all clear, and traces a voxel's own
    /// ray only where it cannot: the same volume as false (every voxel traces its own), faster.
    bool shareShadowRays = true;
    /// Bake one region only (tiled bakes); null: the whole scene. Shadow rays are then traced
    /// one by one (shareShadowRays does not apply).
    const RadianceBakeRegion* region = nullptr;
    Timings* timings = nullptr;
};

/// Lighting of one static voxel, kept with RadianceBakeOptions::keepVoxelLighting.
struct VoxelLighting {
    std::uint32_t x = 0, y = 0, z = 0;  ///< level-0 cell
    Vec3d centre{0, 0, 0};              ///< world
    Vec3f normal{0, 0, 1};              ///< unit mean normal
    Vec3f albedo{0, 0, 0};              ///< linear
    Vec3f emission{0, 0, 0};
    Vec3f direct{0, 0, 0};  ///< irradiance from the punctual lights, after attenuation and shadows
    /// indirect[b]: irradiance gathered by bounce b + 1 alone (cones over the volume lit by
    /// bounces 0 … b, minus what bounce b gathered): the light that arrives after exactly b + 1
    /// diffuse reflections or emissions.
    std::vector<Vec3f> indirect;
};

/// The bake's result.
struct RadianceBake {
    rvol::Volume volume;
    std::vector<VoxelLighting>
        voxels;  ///< with keepVoxelLighting: every static voxel, Morton order
    std::uint64_t staticVoxels = 0, dynamicVoxels = 0;
    /// With BounceGather::Rays: the static voxels that rays reach on both sides of their surface,
    /// each side lit apart for the rays (docs/radiance.md); 0 otherwise.
    std::uint64_t twoSidedVoxels = 0;
    /// How the direct light was computed: method, lights, trees, clusters, cut sizes, search steps,
    /// time; with lightcutsCompare the same for classic Lightcuts and brute force, and the errors.
    ManyLightReport directLight;
};

/// Bakes the radiance volume of @p scene. Same scene and options → the same volume, whatever the
/// thread count. @throws InvalidDataError if the scene has no static triangles; ParameterError
/// for bad options (BounceGather::Rays with a region among them).
[[nodiscard]] RadianceBake bakeRadiance(const Scene& scene, const RadianceBakeOptions& options);

}  // namespace vox
