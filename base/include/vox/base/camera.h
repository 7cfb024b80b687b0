/// @file camera.h
/// @brief The pinhole camera every renderer shares: the CPU ray caster (libvox), the GPU ray
/// caster and final gather (vox::runtime) and the tools compute the same rays from it, bit for
/// bit, in double precision.
#pragma once

#include <vox/base/math.h>

namespace vox {

struct Ray {
    Vec3d origin;
    Vec3d direction;  ///< unit
};

/// A pinhole camera: vertical field of view, rays through pixel centres, row 0 at the top.
struct PinholeCamera {
    Vec3d eye{0, 0, 1}, target{0, 0, 0}, up{0, 1, 0};
    double fovYDegrees = 60;
    int width = 512, height = 512;

    /// The ray from the eye through the centre of pixel (@p x, @p y).
    [[nodiscard]] Ray rayThrough(int x, int y) const;
    /// Angle one pixel subtends at the image centre, in radians.
    [[nodiscard]] double pixelAngle() const;
    /// @throws vox::ParameterError naming `eye`, `target`, `up`, `fovYDegrees` or `size` for a
    /// zero view direction, an up vector parallel to it, a field of view outside (0, 180)
    /// degrees, or an image size outside 1…16384.
    void validate() const;
};

/// The camera's basis, computed once per image rather than once per ray. ray(x, y) is
/// PinholeCamera::rayThrough(x, y); a GPU shader that evaluates direction() must sum
/// forward + right·sx + up·sy left to right, in double, to give the same bits.
struct CameraBasis {
    Vec3d eye, forward, right, up;
    double tanHalf = 0, aspect = 1;
    int width = 1, height = 1;

    explicit CameraBasis(const PinholeCamera& camera);
    [[nodiscard]] Ray ray(int x, int y) const { return rayAt(x + 0.5, y + 0.5); }
    [[nodiscard]] Vec3d direction(int x, int y) const { return ray(x, y).direction; }
    /// The ray through image position (@p px, @p py) in pixels: (0, 0) is the top left corner
    /// of the image, (x + 0.5, y + 0.5) the centre of pixel (x, y).
    [[nodiscard]] Ray rayAt(double px, double py) const;
};

}  // namespace vox
