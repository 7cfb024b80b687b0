// The reference ray caster: Laine & Karras' traversal (tech report section 6 and appendix A),
// written against libvox's block layout. Octree coordinates are [1,2]³ so that POP can read the
// cube position off the float bit patterns.
#include <vox/formats/error.h>
#include <vox/raycast.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>

namespace vox {

// ---- camera ----------------------------------------------------------------------------------

void PinholeCamera::validate() const {
    const Vec3d forward = target - eye;
    if (length(forward) == 0) throw UsageError("camera: --eye and --target are the same point");
    if (length(cross(forward, up)) <= 1e-12 * length(forward) * length(up)) throw UsageError("camera: --up is parallel to the view direction");
    if (!(fovYDegrees > 0 && fovYDegrees < 180)) throw UsageError("camera: --fov must be between 0 and 180 degrees");
    if (width < 1 || height < 1 || width > 16384 || height > 16384) throw UsageError("camera: image size must be 1..16384");
}

namespace {

/// The camera's basis, computed once per image rather than once per ray.
struct CameraBasis {
    Vec3d eye, forward, right, up;
    double tanHalf, aspect;
    int width, height;

    explicit CameraBasis(const PinholeCamera& c)
        : eye(c.eye), forward(normalize(c.target - c.eye)), right(normalize(cross(forward, c.up))), up(cross(right, forward)),
          tanHalf(std::tan(c.fovYDegrees * 0.5 * 3.14159265358979323846 / 180.0)), aspect(double(c.width) / double(c.height)),
          width(c.width), height(c.height) {}

    [[nodiscard]] Ray ray(int x, int y) const {
        const double sx = ((x + 0.5) / width * 2.0 - 1.0) * tanHalf * aspect;
        const double sy = (1.0 - (y + 0.5) / height * 2.0) * tanHalf;
        return {eye, normalize(forward + right * sx + up * sy)};
    }
};

}  // namespace

Ray PinholeCamera::rayThrough(int x, int y) const { return CameraBasis(*this).ray(x, y); }

double PinholeCamera::pixelAngle() const {
    return 2.0 * std::tan(fovYDegrees * 0.5 * 3.14159265358979323846 / 180.0) / height;
}

// ---- ray caster ------------------------------------------------------------------------------

EsvoRayCaster::EsvoRayCaster(const esvo::EsvoPool& pool) : pool_(pool) {
    const auto& m = pool.reader().header().worldToRoot;
    for (int i = 0; i < 12; ++i) a_[i] = m[i];
    const double det = a_[0] * (a_[5] * a_[10] - a_[6] * a_[9]) - a_[1] * (a_[4] * a_[10] - a_[6] * a_[8]) +
                       a_[2] * (a_[4] * a_[9] - a_[5] * a_[8]);
    if (!(std::abs(det) > 0)) throw InvalidDataError(pool.reader().path(), "header: world-to-root transform is singular");
    unitScale_ = std::cbrt(std::abs(det));
    leafSize_ = std::ldexp(1.0, -static_cast<int>(pool.reader().header().leafDepth)) / unitScale_;
}

CastHit EsvoRayCaster::cast(const Ray& ray, const CastOptions& options) const {
    constexpr int kScaleMax = 23;
    const float epsilon = std::ldexp(1.0f, -kScaleMax);
    const std::uint32_t* words = pool_.words();
    struct StackEntry {
        std::uint32_t parent;
        float tMax;
    } stack[kScaleMax + 1];

    // To octree coordinates [1,2]³; t stays the world distance because the direction is
    // transformed without renormalising.
    const auto& o = ray.origin;
    const auto& dw = ray.direction;
    float px = static_cast<float>(a_[0] * o.x + a_[1] * o.y + a_[2] * o.z + a_[3] + 1.0);
    float py = static_cast<float>(a_[4] * o.x + a_[5] * o.y + a_[6] * o.z + a_[7] + 1.0);
    float pz = static_cast<float>(a_[8] * o.x + a_[9] * o.y + a_[10] * o.z + a_[11] + 1.0);
    float dx = static_cast<float>(a_[0] * dw.x + a_[1] * dw.y + a_[2] * dw.z);
    float dy = static_cast<float>(a_[4] * dw.x + a_[5] * dw.y + a_[6] * dw.z);
    float dz = static_cast<float>(a_[8] * dw.x + a_[9] * dw.y + a_[10] * dw.z);
    if (std::abs(dx) < epsilon) dx = std::copysign(epsilon, dx);
    if (std::abs(dy) < epsilon) dy = std::copysign(epsilon, dy);
    if (std::abs(dz) < epsilon) dz = std::copysign(epsilon, dz);

    // t(x) = x·coef − bias, mirrored so that every direction component is negative.
    const float txCoef = 1.0f / -std::abs(dx), tyCoef = 1.0f / -std::abs(dy), tzCoef = 1.0f / -std::abs(dz);
    float txBias = txCoef * px, tyBias = tyCoef * py, tzBias = tzCoef * pz;
    int octantMask = 7;
    if (dx > 0.0f) octantMask ^= 1, txBias = 3.0f * txCoef - txBias;
    if (dy > 0.0f) octantMask ^= 2, tyBias = 3.0f * tyCoef - tyBias;
    if (dz > 0.0f) octantMask ^= 4, tzBias = 3.0f * tzCoef - tzBias;

    float tMin = std::max({2.0f * txCoef - txBias, 2.0f * tyCoef - tyBias, 2.0f * tzCoef - tzBias});
    float tMax = std::min({txCoef - txBias, tyCoef - tyBias, tzCoef - tzBias});
    float h = tMax;
    tMin = std::max(tMin, 0.0f);
    tMax = std::min(tMax, static_cast<float>(std::min(options.tMax, 3.0e38)));
    // Footprint of a pixel at distance t, in root-cube units: t·lodCoef.
    const auto lodCoef = static_cast<float>(options.lodAngle * unitScale_);

    CastHit result;
    std::uint32_t parent = pool_.rootDescriptorWord();
    std::uint32_t descriptor = 0, descriptor2 = 0;  // the parent's two words: topology, contours
    bool haveDescriptor = false;
    float slabT = -1.0f;          // where a contour last raised the span's start, and its normal
    Vec3f slabNormal{0, 0, 0};
    int idx = 0;
    float posX = 1.0f, posY = 1.0f, posZ = 1.0f;
    int scale = kScaleMax - 1;
    float scaleExp2 = 0.5f;
    if (1.5f * txCoef - txBias > tMin) idx ^= 1, posX = 1.5f;
    if (1.5f * tyCoef - tyBias > tMin) idx ^= 2, posY = 1.5f;
    if (1.5f * tzCoef - tzBias > tMin) idx ^= 4, posZ = 1.5f;

    bool hit = false;
    while (scale < kScaleMax) {
        ++result.iterations;
        if (!haveDescriptor) {
            descriptor = words[parent];
            descriptor2 = words[parent + 1];
            haveDescriptor = true;
        }
        const float txCorner = posX * txCoef - txBias;
        const float tyCorner = posY * tyCoef - tyBias;
        const float tzCorner = posZ * tzCoef - tzBias;
        const float tcMax = std::min({txCorner, tyCorner, tzCorner});

        const int slot = idx ^ octantMask ^ 7;  // the child slot in unmirrored space
        const bool valid = (descriptor >> (8 + slot)) & 1u;
        if (valid && tMin <= tMax) {
            const auto level = static_cast<std::uint32_t>(kScaleMax - scale);
            if (lodCoef > 0 && tcMax * lodCoef >= scaleExp2) {  // voxel smaller than the pixel
                hit = true;
                result.level = level;
                break;
            }
            float tvMax = std::min(tMax, tcMax);
            const float half = scaleExp2 * 0.5f;
            const float txCenter = half * txCoef + txCorner;
            const float tyCenter = half * tyCoef + tyCorner;
            const float tzCenter = half * tzCoef + tzCorner;
            // Contour: the voxel's slab, in its local coordinates u = (p − centre) / size.
            float tvMin = tMin;
            bool fromSlab = false;
            Vec3f slabN{0, 0, 0};
            if (options.contours && ((descriptor2 >> slot) & 1u)) {
                const std::uint32_t pointer = descriptor2 >> 8;
                const esvo::Contour c =
                    esvo::Contour::decode(words[parent + pointer + esvo::popc8(descriptor2 & ((1u << slot) - 1u))]);
                // Unmirrored centre of this voxel (a mirrored axis runs 3 − x).
                const float cx = (octantMask & 1) ? posX + half : 3.0f - posX - half;
                const float cy = (octantMask & 2) ? posY + half : 3.0f - posY - half;
                const float cz = (octantMask & 4) ? posZ + half : 3.0f - posZ - half;
                const float nd = float(c.nx) * dx + float(c.ny) * dy + float(c.nz) * dz;
                const float no = float(c.nx) * (px - cx) + float(c.ny) * (py - cy) + float(c.nz) * (pz - cz);
                const float centreOffset = scaleExp2 * float(c.position) * float(esvo::Contour::kStep);
                const float halfThickness = scaleExp2 * float(c.thickness) * float(esvo::Contour::kStep) * 0.5f;
                const float lo = centreOffset - halfThickness - no, hi = centreOffset + halfThickness - no;  // nd·t ∈ [lo, hi]
                if (nd != 0.0f) {
                    float t0 = lo / nd, t1 = hi / nd;
                    if (nd < 0.0f) std::swap(t0, t1);
                    if (t0 > tvMin) {
                        tvMin = t0;
                        fromSlab = true;
                        const float sign = nd > 0.0f ? -1.0f : 1.0f;  // face the ray
                        slabN = {sign * float(c.nx), sign * float(c.ny), sign * float(c.nz)};
                    }
                    tvMax = std::min(tvMax, t1);
                } else if (lo > 0.0f || hi < 0.0f) {
                    tvMax = -1.0f;  // parallel to the slab and outside it
                }
            }
            if (tvMin <= tvMax) {
                bool leaf = !((descriptor >> slot) & 1u) || level >= options.maxLevel;
                std::int32_t offset = static_cast<std::int32_t>(descriptor >> 17);
                if (!leaf && (descriptor & 0x10000u)) {
                    offset = static_cast<std::int32_t>(words[parent + 2 * static_cast<std::uint32_t>(offset)]);
                    leaf = offset == 0;  // child slice not loaded: this is the finest level there is
                }
                if (fromSlab) slabT = tvMin, slabNormal = slabN;
                if (leaf) {
                    hit = true;
                    result.level = level;
                    tMin = tvMin;
                    break;
                }
                // PUSH
                if (tcMax < h) stack[scale] = {parent, tMax};
                h = tcMax;
                offset += static_cast<std::int32_t>(esvo::popc8(descriptor & ((1u << slot) - 1u)));
                parent = static_cast<std::uint32_t>(static_cast<std::int64_t>(parent) + 2 * static_cast<std::int64_t>(offset));
                idx = 0;
                --scale;
                scaleExp2 = half;
                tMin = tvMin;  // the span carries this voxel's slab down to its children
                tMax = tvMax;
                if (txCenter > tMin) idx ^= 1, posX += scaleExp2;
                if (tyCenter > tMin) idx ^= 2, posY += scaleExp2;
                if (tzCenter > tMin) idx ^= 4, posZ += scaleExp2;
                haveDescriptor = false;
                continue;
            }
        }

        // ADVANCE
        int stepMask = 0;
        if (txCorner <= tcMax) stepMask ^= 1, posX -= scaleExp2;
        if (tyCorner <= tcMax) stepMask ^= 2, posY -= scaleExp2;
        if (tzCorner <= tcMax) stepMask ^= 4, posZ -= scaleExp2;
        tMin = tcMax;
        idx ^= stepMask;
        if ((idx & stepMask) != 0) {
            // POP: the highest bit where the old and new positions differ gives the scale.
            std::uint32_t differing = 0;
            if (stepMask & 1) differing |= std::bit_cast<std::uint32_t>(posX) ^ std::bit_cast<std::uint32_t>(posX + scaleExp2);
            if (stepMask & 2) differing |= std::bit_cast<std::uint32_t>(posY) ^ std::bit_cast<std::uint32_t>(posY + scaleExp2);
            if (stepMask & 4) differing |= std::bit_cast<std::uint32_t>(posZ) ^ std::bit_cast<std::uint32_t>(posZ + scaleExp2);
            scale = static_cast<int>(std::bit_cast<std::uint32_t>(static_cast<float>(differing)) >> 23) - 127;
            if (scale >= kScaleMax) break;
            scaleExp2 = std::bit_cast<float>(static_cast<std::uint32_t>(scale - kScaleMax + 127) << 23);
            parent = stack[scale].parent;
            tMax = stack[scale].tMax;
            const std::uint32_t shx = std::bit_cast<std::uint32_t>(posX) >> scale;
            const std::uint32_t shy = std::bit_cast<std::uint32_t>(posY) >> scale;
            const std::uint32_t shz = std::bit_cast<std::uint32_t>(posZ) >> scale;
            posX = std::bit_cast<float>(shx << scale);
            posY = std::bit_cast<float>(shy << scale);
            posZ = std::bit_cast<float>(shz << scale);
            idx = static_cast<int>((shx & 1u) | ((shy & 1u) << 1) | ((shz & 1u) << 2));
            h = 0.0f;
            haveDescriptor = false;
        }
    }
    if (!hit) return result;

    result.hit = true;
    result.t = tMin;
    // The face the ray entered through: the axis whose entry plane it crossed last, or the
    // contour plane if that is where the span began.
    const float txEntry = (posX + scaleExp2) * txCoef - txBias;
    const float tyEntry = (posY + scaleExp2) * tyCoef - tyBias;
    const float tzEntry = (posZ + scaleExp2) * tzCoef - tzBias;
    Vec3d n{0, 0, 0};
    if (slabT == tMin && slabT >= std::max({txEntry, tyEntry, tzEntry}))
        n = {slabNormal.x, slabNormal.y, slabNormal.z};
    else if (txEntry >= tyEntry && txEntry >= tzEntry)
        n.x = dx > 0 ? -1 : 1;
    else if (tyEntry >= tzEntry)
        n.y = dy > 0 ? -1 : 1;
    else
        n.z = dz > 0 ? -1 : 1;
    // Normals transform with the inverse transpose; for libvox's uniform scale this is n itself,
    // but a general affine header is allowed.
    const Vec3d nw{a_[0] * n.x + a_[4] * n.y + a_[8] * n.z, a_[1] * n.x + a_[5] * n.y + a_[9] * n.z,
                   a_[2] * n.x + a_[6] * n.y + a_[10] * n.z};
    const Vec3d nn = normalize(nw);
    result.normal = {static_cast<float>(nn.x), static_cast<float>(nn.y), static_cast<float>(nn.z)};
    return result;
}

RenderBuffers renderPixels(const PinholeCamera& camera, const std::function<CastHit(const Ray&)>& cast) {
    camera.validate();
    RenderBuffers out;
    out.width = camera.width;
    out.height = camera.height;
    const std::size_t pixels = std::size_t(camera.width) * std::size_t(camera.height);
    out.depth.assign(pixels, std::numeric_limits<float>::infinity());
    out.normal.assign(pixels, Vec3f{0, 0, 0});
    out.iterations.assign(pixels, 0);
    out.level.assign(pixels, 0);
    std::atomic<std::uint64_t> hits{0};
    const CameraBasis basis(camera);
    const auto start = std::chrono::steady_clock::now();
    tbb::parallel_for(tbb::blocked_range<int>(0, camera.height, 4), [&](const tbb::blocked_range<int>& rows) {
        std::uint64_t localHits = 0;
        for (int y = rows.begin(); y != rows.end(); ++y)
            for (int x = 0; x < camera.width; ++x) {
                const CastHit h = cast(basis.ray(x, y));
                const std::size_t i = std::size_t(y) * std::size_t(camera.width) + std::size_t(x);
                out.iterations[i] = h.iterations;
                if (!h.hit) continue;
                ++localHits;
                out.depth[i] = h.t;
                out.normal[i] = h.normal;
                out.level[i] = static_cast<std::uint8_t>(h.level);
            }
        hits += localHits;
    });
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    out.hits = hits;
    return out;
}

RenderBuffers renderEsvo(const EsvoRayCaster& caster, const PinholeCamera& camera, const CastOptions& options) {
    return renderPixels(camera, [&](const Ray& ray) { return caster.cast(ray, options); });
}

}  // namespace vox
