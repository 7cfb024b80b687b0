/// @file math.h
/// @brief The small vector, matrix and bounds types every libvox layer uses (vox::base).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <string>

namespace vox {

template <typename T>
struct Vec2 {
    T x{}, y{};
    constexpr T& operator[](int i) { return i == 0 ? x : y; }
    constexpr const T& operator[](int i) const { return i == 0 ? x : y; }
    friend constexpr Vec2 operator+(Vec2 a, Vec2 b) { return {a.x + b.x, a.y + b.y}; }
    friend constexpr Vec2 operator-(Vec2 a, Vec2 b) { return {a.x - b.x, a.y - b.y}; }
    friend constexpr Vec2 operator*(Vec2 a, T s) { return {a.x * s, a.y * s}; }
    friend constexpr bool operator==(Vec2 a, Vec2 b) = default;
};

template <typename T>
struct Vec3 {
    T x{}, y{}, z{};
    constexpr T& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
    constexpr const T& operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
    friend constexpr Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
    friend constexpr Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
    friend constexpr Vec3 operator-(Vec3 a) { return {-a.x, -a.y, -a.z}; }
    friend constexpr Vec3 operator*(Vec3 a, T s) { return {a.x * s, a.y * s, a.z * s}; }
    friend constexpr Vec3 operator*(T s, Vec3 a) { return {a.x * s, a.y * s, a.z * s}; }
    friend constexpr Vec3 operator*(Vec3 a, Vec3 b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }
    friend constexpr Vec3 operator/(Vec3 a, T s) { return {a.x / s, a.y / s, a.z / s}; }
    constexpr Vec3& operator+=(Vec3 b) {
        x += b.x;
        y += b.y;
        z += b.z;
        return *this;
    }
    friend constexpr bool operator==(Vec3 a, Vec3 b) = default;
};

template <typename T>
struct Vec4 {
    T x{}, y{}, z{}, w{};
    constexpr T& operator[](int i) { return i == 0 ? x : (i == 1 ? y : (i == 2 ? z : w)); }
    constexpr const T& operator[](int i) const {
        return i == 0 ? x : (i == 1 ? y : (i == 2 ? z : w));
    }
    friend constexpr Vec4 operator+(Vec4 a, Vec4 b) {
        return {a.x + b.x, a.y + b.y, a.z + b.z, a.w + b.w};
    }
    friend constexpr Vec4 operator*(Vec4 a, T s) { return {a.x * s, a.y * s, a.z * s, a.w * s}; }
    friend constexpr Vec4 operator*(Vec4 a, Vec4 b) {
        return {a.x * b.x, a.y * b.y, a.z * b.z, a.w * b.w};
    }
    friend constexpr bool operator==(Vec4 a, Vec4 b) = default;
};

using Vec2f = Vec2<float>;
using Vec3f = Vec3<float>;
using Vec3d = Vec3<double>;
using Vec4f = Vec4<float>;

template <typename T>
constexpr T dot(Vec3<T> a, Vec3<T> b) {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}
template <typename T>
constexpr Vec3<T> cross(Vec3<T> a, Vec3<T> b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
template <typename T>
inline T length(Vec3<T> a) {
    return std::sqrt(dot(a, a));
}
/// Unit vector along @p a, or the zero vector when @p a has no length.
template <typename T>
inline Vec3<T> normalize(Vec3<T> a) {
    const T len = length(a);
    return len > T(0) ? a / len : Vec3<T>{};
}
template <typename T>
inline bool isFinite(Vec3<T> a) {
    return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z);
}

/// An orthonormal frame (t, b, n) with the unit vector @p normal as n, continuous in n except
/// where n.z changes sign (Duff et al. 2017, "Building an Orthonormal Basis, Revisited"):
/// deterministic, so directions built in it are the same on every run and thread.
struct OrthonormalFrame {
    Vec3d t, b, n;
    explicit OrthonormalFrame(Vec3d normal) : n(normal) {
        const double sign = std::copysign(1.0, n.z);
        const double a = -1.0 / (sign + n.z);
        const double c = n.x * n.y * a;
        t = {1.0 + sign * n.x * n.x * a, sign * c, -sign * n.x};
        b = {c, sign + n.y * n.y * a, -n.y};
    }
    /// The direction with coordinates (x, y, z) in the frame.
    [[nodiscard]] Vec3d toWorld(double x, double y, double z) const {
        return t * x + b * y + n * z;
    }
};

/// 4×4 affine transform in double precision, column-major as glTF stores it: m[col][row].
struct Mat4d {
    std::array<std::array<double, 4>, 4> m{
        {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}}};

    static Mat4d identity() { return {}; }
    friend Mat4d operator*(const Mat4d& a, const Mat4d& b) {
        Mat4d r;
        for (int c = 0; c < 4; ++c)
            for (int row = 0; row < 4; ++row) {
                double s = 0;
                for (int k = 0; k < 4; ++k) s += a.m[k][row] * b.m[c][k];
                r.m[c][row] = s;
            }
        return r;
    }
    [[nodiscard]] Vec3d transformPoint(Vec3d p) const {
        return {m[0][0] * p.x + m[1][0] * p.y + m[2][0] * p.z + m[3][0],
                m[0][1] * p.x + m[1][1] * p.y + m[2][1] * p.z + m[3][1],
                m[0][2] * p.x + m[1][2] * p.y + m[2][2] * p.z + m[3][2]};
    }
    [[nodiscard]] Vec3d transformVector(Vec3d v) const {
        return {m[0][0] * v.x + m[1][0] * v.y + m[2][0] * v.z,
                m[0][1] * v.x + m[1][1] * v.y + m[2][1] * v.z,
                m[0][2] * v.x + m[1][2] * v.y + m[2][2] * v.z};
    }
    /// Determinant of the upper 3×3 (negative: the transform mirrors, flipping winding).
    [[nodiscard]] double determinant3() const {
        return m[0][0] * (m[1][1] * m[2][2] - m[2][1] * m[1][2]) -
               m[1][0] * (m[0][1] * m[2][2] - m[2][1] * m[0][2]) +
               m[2][0] * (m[0][1] * m[1][2] - m[1][1] * m[0][2]);
    }
    /// Transform for normals: the inverse transpose of the upper 3×3, up to a positive scale
    /// (the cofactor matrix times the determinant's sign). Exact even for singular transforms.
    [[nodiscard]] Mat4d normalMatrix() const {
        Mat4d r;
        const auto& a = m;
        const double s = determinant3() < 0 ? -1.0 : 1.0;
        // cofactor(row i, col j) of the 3x3 with a[col][row]
        auto at = [&](int row, int col) { return a[col][row]; };
        for (int row = 0; row < 3; ++row)
            for (int col = 0; col < 3; ++col) {
                const int r0 = (row + 1) % 3, r1 = (row + 2) % 3, c0 = (col + 1) % 3,
                          c1 = (col + 2) % 3;
                r.m[col][row] = s * (at(r0, c0) * at(r1, c1) - at(r0, c1) * at(r1, c0));
            }
        r.m[3] = {0, 0, 0, 1};
        return r;
    }
    [[nodiscard]] bool isFinite() const {
        for (const auto& col : m)
            for (double v : col)
                if (!std::isfinite(v)) return false;
        return true;
    }
};

/// Axis-aligned bounding box; empty until a point is added.
struct Bounds3f {
    Vec3f min{std::numeric_limits<float>::infinity(), std::numeric_limits<float>::infinity(),
              std::numeric_limits<float>::infinity()};
    Vec3f max{-std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity(),
              -std::numeric_limits<float>::infinity()};

    [[nodiscard]] bool empty() const { return min.x > max.x || min.y > max.y || min.z > max.z; }
    void add(Vec3f p) {
        min = {std::min(min.x, p.x), std::min(min.y, p.y), std::min(min.z, p.z)};
        max = {std::max(max.x, p.x), std::max(max.y, p.y), std::max(max.z, p.z)};
    }
    void add(const Bounds3f& b) {
        if (b.empty()) return;
        add(b.min);
        add(b.max);
    }
    [[nodiscard]] Vec3f extent() const { return empty() ? Vec3f{} : max - min; }
};

/// The vector written "x,y,z" (three finite numbers, nothing else), or none.
inline std::optional<Vec3d> parseVec3(const std::string& text) {
    Vec3d v;
    char tail = 0;
    if (std::sscanf(text.c_str(), "%lf,%lf,%lf%c", &v.x, &v.y, &v.z, &tail) != 3 || !isFinite(v))
        return std::nullopt;
    return v;
}

/// @p v with each component converted to @p To (double → float rounds to nearest).
template <typename To, typename From>
constexpr Vec3<To> vec3Cast(Vec3<From> v) {
    return {static_cast<To>(v.x), static_cast<To>(v.y), static_cast<To>(v.z)};
}

/// The largest float ≤ @p v (a float box built from these holds the double value).
inline float floatAtOrBelow(double v) {
    const float f = static_cast<float>(v);
    return double(f) <= v ? f : std::nextafter(f, -std::numeric_limits<float>::infinity());
}
/// The smallest float ≥ @p v.
inline float floatAtOrAbove(double v) {
    const float f = static_cast<float>(v);
    return double(f) >= v ? f : std::nextafter(f, std::numeric_limits<float>::infinity());
}

}  // namespace vox
