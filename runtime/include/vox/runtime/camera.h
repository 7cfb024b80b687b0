/// @file camera.h
/// @brief The runtime's pinhole camera: the same rays as libvox's PinholeCamera (and so as
/// `voxinspect render`), without linking libvox.
#pragma once

#include <array>

namespace vox::runtime {

using Vec3d = std::array<double, 3>;

/// Vertical field of view, rays through pixel centres, row 0 at the top. rayDirection() is
/// bit for bit libvox's PinholeCamera::rayThrough(x, y).direction: the GPU ray caster evaluates
/// the same double expressions in the same order.
struct Camera {
    Vec3d eye{0, 0, 1}, target{0, 0, 0}, up{0, 1, 0};
    double fovYDegrees = 60;
    int width = 512, height = 512;

    /// Throws vox::UsageError for a zero view direction, an up vector parallel to it, a bad field
    /// of view or image size (the messages of PinholeCamera::validate).
    void validate() const;
    /// Angle one pixel subtends at the image centre, in radians (CastOptions::lodAngle).
    [[nodiscard]] double pixelAngle() const;
    /// Unit direction of the ray through the centre of pixel (@p x, @p y).
    [[nodiscard]] Vec3d rayDirection(int x, int y) const;
};

/// The camera's basis as the ray caster uses it (computed once per image).
struct CameraBasis {
    Vec3d eye, forward, right, up;
    double tanHalf = 0, aspect = 1;
    int width = 1, height = 1;
    explicit CameraBasis(const Camera& camera);
    [[nodiscard]] Vec3d direction(int x, int y) const;
};

}  // namespace vox::runtime
