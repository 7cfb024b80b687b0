// Sampling the anisotropic mip chain and tracing cones through it (Gui et al. 2019, 2.3–2.4).
#include <vox/radiance_field.h>

#include <algorithm>
#include <cmath>

namespace vox {

using rvol::kBlockCells;
using rvol::kBlockTexels;
using rvol::Texel;

RadianceField::RadianceField(const rvol::Volume& volume)
    : volume_(&volume),
      index_(volume.levels.size()),
      origin_{volume.origin[0], volume.origin[1], volume.origin[2]},
      size_(volume.size),
      // The levels present (depth + 1 once allocated).
      depth_(static_cast<std::uint32_t>(volume.levels.size()) - 1) {
    finestCell_ = volume.cellSize(0);
    for (std::size_t l = 0; l < volume.levels.size(); ++l) {
        const rvol::Level& level = volume.levels[l];
        LevelIndex& index = index_[l];
        index.blocksPerAxis =
            std::max<std::uint32_t>(1, (level.resolution + kBlockCells - 1) / kBlockCells);
        const std::size_t n =
            std::size_t{index.blocksPerAxis} * index.blocksPerAxis * index.blocksPerAxis;
        index.blocks.assign(n, -1);
        for (std::size_t b = 0; b < level.blocks.size(); ++b) {
            const auto c = rvol::demorton3(level.blocks[b]);
            index.blocks[(std::size_t{c[2]} * index.blocksPerAxis + c[1]) * index.blocksPerAxis +
                         c[0]] = static_cast<std::int32_t>(b);
        }
    }
}

RadianceField::RadianceField(const rvol::RvolSampler& sampler)
    : sampler_(&sampler),
      origin_{sampler.origin()[0], sampler.origin()[1], sampler.origin()[2]},
      size_(sampler.size()),
      depth_(sampler.depth()),
      finestCell_(sampler.size() / double(std::uint64_t{1} << sampler.depth())) {}

const Texel* RadianceField::cellTexels(std::uint32_t level, std::uint32_t x, std::uint32_t y,
                                       std::uint32_t z) const noexcept {
    const std::int32_t block = index_[level].blockOf(x, y, z);
    if (block < 0) return nullptr;
    const rvol::Level& l = volume_->levels[level];
    return l.texels.data() +
           rvol::Level::texelIndex(static_cast<std::size_t>(block), l.channels, 0, x, y, z);
}

Texel RadianceField::sample(std::uint32_t level, Vec3d p, Vec3d dir) const {
    if (sampler_) return sampler_->sampleDirectional(level, {p.x, p.y, p.z}, {dir.x, dir.y, dir.z});
    const rvol::Level& l = volume_->levels[level];
    const double cellSize = volume_->cellSize(level);
    const double last = l.resolution - 1.0;
    double u[3];
    for (int axis = 0; axis < 3; ++axis)
        u[axis] = std::clamp((p[axis] - origin_[axis]) / cellSize - 0.5, 0.0, last);
    std::uint32_t c0[3], c1[3];
    double f[3];
    for (int axis = 0; axis < 3; ++axis) {
        const double fl = std::floor(u[axis]);
        c0[axis] = static_cast<std::uint32_t>(fl);
        c1[axis] = std::min(c0[axis] + 1, l.resolution - 1);
        f[axis] = u[axis] - fl;
    }
    // Channel offsets: one channel at level 0, else the three facing the direction.
    std::size_t offsets[3] = {0, 0, 0};
    std::uint32_t channelCount = 1;
    if (l.channels == rvol::kDirections) {
        channelCount = 3;
        for (int axis = 0; axis < 3; ++axis)
            offsets[axis] =
                static_cast<std::size_t>(2 * axis + (dir[axis] < 0 ? 1 : 0)) * kBlockTexels;
    }
    // The corners' blocks: a corner shares its block with the corner below it along an axis
    // where both cells fall in the same block (7 of 8 cells per axis), so most samples look up
    // one block instead of eight.
    const LevelIndex& index = index_[level];
    std::int32_t blockOf[8];
    for (int corner = 0; corner < 8; ++corner) {
        const int axis = corner >= 4 ? 2 : corner >= 2 ? 1 : 0;
        if (corner > 0 && c0[axis] / kBlockCells == c1[axis] / kBlockCells) {
            blockOf[corner] = blockOf[corner & ~(1 << axis)];
            continue;
        }
        const std::uint32_t x = corner & 1 ? c1[0] : c0[0], y = corner & 2 ? c1[1] : c0[1],
                            z = corner & 4 ? c1[2] : c0[2];
        blockOf[corner] = index.blockOf(x, y, z);
    }
    double sums[3][4] = {};
    for (int corner = 0; corner < 8; ++corner) {
        const double w = (corner & 1 ? f[0] : 1 - f[0]) * (corner & 2 ? f[1] : 1 - f[1]) *
                         (corner & 4 ? f[2] : 1 - f[2]);
        if (w <= 0 || blockOf[corner] < 0) continue;
        const Texel* t =
            l.texels.data() +
            rvol::Level::texelIndex(static_cast<std::size_t>(blockOf[corner]), l.channels, 0,
                                    corner & 1 ? c1[0] : c0[0], corner & 2 ? c1[1] : c0[1],
                                    corner & 4 ? c1[2] : c0[2]);
        for (std::uint32_t c = 0; c < channelCount; ++c) {
            const Texel& v = t[offsets[c]];
            sums[c][0] += w * v.r;
            sums[c][1] += w * v.g;
            sums[c][2] += w * v.b;
            sums[c][3] += w * v.a;
        }
    }
    if (channelCount == 1)
        return {static_cast<float>(sums[0][0]), static_cast<float>(sums[0][1]),
                static_cast<float>(sums[0][2]), static_cast<float>(sums[0][3])};
    std::array<Texel, 3> facing{};
    for (int axis = 0; axis < 3; ++axis)
        facing[axis] = {static_cast<float>(sums[axis][0]), static_cast<float>(sums[axis][1]),
                        static_cast<float>(sums[axis][2]), static_cast<float>(sums[axis][3])};
    return rvol::combineDirectional(facing, {dir.x, dir.y, dir.z});
}

Texel RadianceField::sampleLod(double level, Vec3d p, Vec3d dir) const {
    level = std::clamp(level, 0.0, static_cast<double>(depth_));
    const auto lo = static_cast<std::uint32_t>(std::floor(level));
    const double f = level - lo;
    const Texel a = sample(lo, p, dir);
    if (f <= 0 || lo >= depth_) return a;
    const Texel b = sample(lo + 1, p, dir);
    const auto mix = [f](float x, float y) { return static_cast<float>(x + (y - x) * f); };
    return {mix(a.r, b.r), mix(a.g, b.g), mix(a.b, b.b), mix(a.a, b.a)};
}

void RadianceField::setFarField(const RadianceField* far, Vec3d nearLo, Vec3d nearHi) noexcept {
    far_ = far;
    nearLo_ = nearLo;
    nearHi_ = nearHi;
    farLevelOffset_ = far ? std::round(std::log2(far->finestCell_ / finestCell_)) : 0;
}

Texel RadianceField::sampleNearOrFar(double level, Vec3d p, Vec3d dir) const {
    if (far_) {
        // The two cells per axis that the upper of the two levels sampleLod blends filters (they
        // hold the lower level's) must lie inside the near box: a cell that straddles its edge
        // holds only some of its voxels, and reads too dark and too clear.
        const double c = finestCell_ * std::exp2(std::ceil(std::max(level, 0.0)));
        for (int axis = 0; axis < 3; ++axis) {
            const double o = origin_[axis];
            const double first = std::floor((p[axis] - o) / c - 0.5);
            if (o + first * c < nearLo_[axis] || o + (first + 2) * c > nearHi_[axis])
                return far_->sampleLod(std::max(level - farLevelOffset_, 0.0), p, dir);
        }
    }
    return sampleLod(level, p, dir);
}

RadianceField::ConeResult RadianceField::traceCone(const Cone& cone, double aoLambda,
                                                   bool opacityOnly) const {
    ConeResult out;
    // With a far field the cone runs through the far field's (the world's) cube.
    const RadianceField& outer = far_ ? *far_ : *this;
    const double size = outer.size_;
    const Vec3d lo = outer.origin_;
    const Vec3d hi = lo + Vec3d{size, size, size};
    const double top = static_cast<double>(outer.depth_) + (far_ ? farLevelOffset_ : 0);
    double t = std::max(cone.start, 0.5 * finestCell_);
    double opacity = 0, occlusion = 0;
    Vec3d radiance{0, 0, 0};
    const bool clampToPlane =
        cone.planeNormal.x != 0 || cone.planeNormal.y != 0 || cone.planeNormal.z != 0;
    while (t < cone.maxDistance && opacity < 0.995) {
        const Vec3d p = cone.origin + cone.dir * t;
        const double diameter = std::max(2 * t * cone.tanHalfAngle, finestCell_);
        // Geometry reaches the cube's faces (the cube encloses the scene's bounds): march until the
        // footprint has left it, so surfaces on the faces get their full opacity.
        const double margin = 0.5 * diameter;
        if (p.x < lo.x - margin || p.y < lo.y - margin || p.z < lo.z - margin ||
            p.x > hi.x + margin || p.y > hi.y + margin || p.z > hi.z + margin)
            break;
        double footprint = diameter;
        if (clampToPlane) {
            // Measured where the sample reads: beyond the cube the sampler clamps to the edge
            // cells, which may lie behind the plane though p does not (a floor's underside, its
            // cones leaving through the cube's face below, would read the floor's lit top).
            Vec3d read = p;
            for (int axis = 0; axis < 3; ++axis)
                read[axis] = std::clamp(p[axis], lo[axis], hi[axis]);
            footprint =
                std::max(finestCell_,
                         std::min(footprint, dot(read - cone.planePoint, cone.planeNormal) / 1.5));
        }
        const double level = std::log2(footprint / finestCell_);
        if (level > top) break;
        const double step = 0.5 * diameter;
        const Texel s = sampleNearOrFar(level, p, cone.dir);
        if (s.a > 1e-6f) {
            // The sample's opacity is for a footprint-long path; the step covers half of it, so
            // its transmittance is the square root of the sample's.
            const double a = std::clamp(double(s.a), 0.0, 1.0);
            const double corrected = 1 - std::sqrt(1 - std::min(a, 0.999999));
            if (!opacityOnly) radiance += Vec3d{s.r, s.g, s.b} * ((1 - opacity) * corrected / a);
            occlusion += (1 - occlusion) * corrected / (1 + aoLambda * 0.5 * diameter / size);
            opacity += (1 - opacity) * corrected;
        }
        t += step;
    }
    out.radiance = radiance;
    out.opacity = opacity;
    out.occlusion = occlusion;
    return out;
}

RadianceField::Gather RadianceField::gatherDiffuse(Vec3d point, Vec3d normal, double offset,
                                                   double aoLambda) const {
    const DiffuseCones& cones = diffuseCones();
    const std::array<Vec3d, DiffuseCones::kRing + 1> axes = cones.axes(normal);
    // The cones' samples stay in front of a plane one cell above the surface point: clear of the
    // surface's own voxels, which would otherwise occlude the cones that leave it.
    const Vec3d origin = point + normal * offset;
    Gather out;
    double weightSum = 0;
    for (std::size_t i = 0; i <= DiffuseCones::kRing; ++i) {
        const double weight = cones.weight(i);
        const ConeResult r = traceCone(
            {origin, axes[i], cones.tanHalf, 0, 1e30, point + normal * finestCell_, normal},
            aoLambda);
        out.irradiance += r.radiance * weight;
        out.occlusion += r.occlusion * weight;
        weightSum += weight;
    }
    out.occlusion /= weightSum;
    return out;
}

std::array<Vec3d, RadianceField::DiffuseCones::kRing + 1> RadianceField::DiffuseCones::axes(
    Vec3d normal) const {
    // A tangent frame that depends only on the normal (deterministic).
    const Vec3d helper = std::abs(normal.x) < 0.9 ? Vec3d{1, 0, 0} : Vec3d{0, 1, 0};
    const Vec3d tangent = normalize(cross(helper, normal));
    const Vec3d bitangent = cross(normal, tangent);
    std::array<Vec3d, kRing + 1> out;
    out[0] = normal;
    for (std::size_t i = 0; i < kRing; ++i)
        out[i + 1] = normalize(normal * cosTilt +
                               (tangent * cosAzimuth[i] + bitangent * sinAzimuth[i]) * sinTilt);
    return out;
}

const RadianceField::DiffuseCones& RadianceField::diffuseCones() noexcept {
    static const DiffuseCones cones = [] {
        constexpr double kPi = 3.14159265358979323846;
        constexpr double kHalf = 28 * kPi / 180, kTilt = 55 * kPi / 180;
        DiffuseCones c;
        c.tanHalf = std::tan(kHalf);
        c.cosTilt = std::cos(kTilt);
        c.sinTilt = std::sin(kTilt);
        // The exact cosine-weighted solid angle of a cone of half-angle h whose axis makes angle
        // θ with the normal (wholly above the horizon) is cos θ · π sin² h. With h = 28° and
        // θ = 55° the seven sum to 0.979 π: the cones nearly tile the cosine-weighted hemisphere,
        // and scaling them to sum to π (uniform radiance L gives π·L) changes each by 2 %.
        const double cap = kPi * std::sin(kHalf) * std::sin(kHalf);
        const double centre = cap, ring = c.cosTilt * cap;
        const double norm = kPi / (centre + DiffuseCones::kRing * ring);
        c.centreWeight = centre * norm;
        c.ringWeight = ring * norm;
        for (std::size_t i = 0; i < DiffuseCones::kRing; ++i) {
            const double phi = 2 * kPi * double(i) / DiffuseCones::kRing;
            c.cosAzimuth[i] = std::cos(phi);
            c.sinAzimuth[i] = std::sin(phi);
        }
        return c;
    }();
    return cones;
}

}  // namespace vox
