#include <vox/lighting.h>

#include <algorithm>
#include <cmath>

namespace vox {

bool lightArrival(const Light& light, Vec3d point, LightArrival& out) {
    const Vec3d color{light.color.x * double(light.intensity),
                      light.color.y * double(light.intensity),
                      light.color.z * double(light.intensity)};
    if (light.type == Light::Type::Directional) {
        out.toLight = -normalize(Vec3d{light.direction.x, light.direction.y, light.direction.z});
        out.distance = std::numeric_limits<double>::infinity();
        out.irradiance = color;
        return true;
    }
    const Vec3d offset = Vec3d{light.position.x, light.position.y, light.position.z} - point;
    const double d2 = dot(offset, offset);
    if (!(d2 > 0)) return false;
    const double d = std::sqrt(d2);
    out.toLight = offset / d;
    out.distance = d;
    double falloff = 1.0 / d2;
    if (light.range > 0) {
        if (d >= light.range) return false;
        const double r = d / light.range;
        const double window = std::clamp(1.0 - r * r * r * r, 0.0, 1.0);
        falloff *= window * window;
    }
    if (light.type == Light::Type::Spot) {
        const Vec3d axis =
            normalize(Vec3d{light.direction.x, light.direction.y, light.direction.z});
        const double cosAngle = -dot(axis, out.toLight);
        const double cosOuter = std::cos(double(light.outerConeAngle));
        const double cosInner = std::cos(double(light.innerConeAngle));
        const double scale = 1.0 / std::max(1e-3, cosInner - cosOuter);
        const double t = std::clamp((cosAngle - cosOuter) * scale, 0.0, 1.0);
        if (t <= 0) return false;
        falloff *= t * t;
    }
    if (!(falloff > 0)) return false;
    out.irradiance = color * falloff;
    return true;
}

AdaptiveAttenuation adaptiveAttenuation(const VoxelNormals& normals) {
    AdaptiveAttenuation out;
    for (int axis = 0; axis < 3; ++axis)
        out.mean[axis] = double(normals.moments[std::size_t(2 * axis)]) -
                         double(normals.moments[std::size_t(2 * axis + 1)]);
    // Flat from |m| = 0.99 (normals within about ±14°, and float moments' rounding), folded below
    // 0.9 (a fold of 50° or more).
    out.flat = std::clamp((length(out.mean) - 0.9) / 0.09, 0.0, 1.0);
    return out;
}

double attenuate(Attenuation mode, const VoxelNormals& normals, Vec3d toLight) {
    // Renormalised in double: a float unit vector is 1 ± 3e-8 long, and Lightcuts' bounds
    // (LightcutPoint::voxel) must see exactly the normal this does.
    const Vec3d n = normalize(Vec3d{normals.mean.x, normals.mean.y, normals.mean.z});
    double v = 0;
    switch (mode) {
        case Attenuation::Weighted:
            for (int axis = 0; axis < 3; ++axis) {
                const double l = toLight[axis];
                v += l > 0 ? normals.moments[2 * axis] * l : normals.moments[2 * axis + 1] * -l;
            }
            return v;
        case Attenuation::Adaptive: {
            const AdaptiveAttenuation a = adaptiveAttenuation(normals);
            const double cosine = a.flat > 0 ? std::max(0.0, dot(normalize(a.mean), toLight)) : 0;
            if (a.flat == 1) return cosine;
            return a.flat * cosine +
                   (1 - a.flat) * attenuate(Attenuation::Weighted, normals, toLight);
        }
        case Attenuation::Paper:
            for (int axis = 0; axis < 3; ++axis) {
                const double l = toLight[axis];
                if (n[axis] * l > 0) v += n[axis] * n[axis] * std::abs(l);
            }
            return v;
        case Attenuation::Average:
            return std::max(0.0, dot(n, toLight));
    }
    return 0;
}

}  // namespace vox
