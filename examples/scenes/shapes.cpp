#include "shapes.h"

#include <cmath>
#include <numbers>

namespace vox::scenes {

GltfBuilder::Primitive boxPrimitive(std::array<float, 3> lo, std::array<float, 3> hi,
                                    int material) {
    GltfBuilder::Primitive p;
    p.material = material;
    // For each face: the axis it faces along, its sign, and the two in-plane axes (u, v) chosen
    // so that u × v points outwards (counter-clockwise front faces).
    struct Face {
        int axis;
        float sign;
        int u, v;
    };
    const Face faces[6] = {{0, 1, 1, 2},  {0, -1, 2, 1}, {1, 1, 2, 0},
                           {1, -1, 0, 2}, {2, 1, 0, 1},  {2, -1, 1, 0}};
    for (const Face& f : faces) {
        const std::uint32_t base = static_cast<std::uint32_t>(p.positions.size() / 3);
        for (int corner = 0; corner < 4; ++corner) {
            const int cu = (corner == 1 || corner == 2) ? 1 : 0, cv = corner >= 2 ? 1 : 0;
            std::array<float, 3> q{};
            q[f.axis] = f.sign > 0 ? hi[f.axis] : lo[f.axis];
            q[f.u] = cu ? hi[f.u] : lo[f.u];
            q[f.v] = cv ? hi[f.v] : lo[f.v];
            p.positions.insert(p.positions.end(), q.begin(), q.end());
            std::array<float, 3> n{};
            n[f.axis] = f.sign;
            p.normals.insert(p.normals.end(), n.begin(), n.end());
            p.uvs.push_back(static_cast<float>(cu));
            p.uvs.push_back(static_cast<float>(1 - cv));
        }
        p.indices.insert(p.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
    }
    return p;
}

GltfBuilder::Primitive spherePrimitive(float radius, int rings, int segments, int material) {
    GltfBuilder::Primitive p;
    p.material = material;
    for (int r = 0; r <= rings; ++r) {
        const double theta = std::numbers::pi * r / rings;
        for (int s = 0; s <= segments; ++s) {
            const double phi = 2 * std::numbers::pi * s / segments;
            const float n[3] = {static_cast<float>(std::sin(theta) * std::cos(phi)),
                                static_cast<float>(std::cos(theta)),
                                static_cast<float>(-std::sin(theta) * std::sin(phi))};
            for (float c : n) {
                p.normals.push_back(c);
                p.positions.push_back(c * radius);
            }
            p.uvs.push_back(static_cast<float>(s) / segments);
            p.uvs.push_back(static_cast<float>(r) / rings);
        }
    }
    const auto at = [&](int r, int s) {
        return static_cast<std::uint32_t>(r * (segments + 1) + s);
    };
    for (int r = 0; r < rings; ++r)
        for (int s = 0; s < segments; ++s) {
            if (r > 0) p.indices.insert(p.indices.end(), {at(r, s), at(r + 1, s), at(r, s + 1)});
            if (r < rings - 1)
                p.indices.insert(p.indices.end(), {at(r, s + 1), at(r + 1, s), at(r + 1, s + 1)});
        }
    return p;
}

std::array<double, 4> rotationFromMinusZ(std::array<double, 3> d) {
    const double len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (double& c : d) c /= len;
    // Half-way quaternion between a = (0, 0, -1) and d: (a × d, 1 + a·d), normalised.
    const double x = d[1], y = -d[0], z = 0.0, w = 1.0 - d[2];
    if (w < 1e-9) return {0, 1, 0, 0};  // d = +Z: half a turn about Y
    const double n = std::sqrt(x * x + y * y + z * z + w * w);
    return {x / n, y / n, z / n, w / n};
}

}  // namespace vox::scenes
