// The pinhole camera, with libvox's PinholeCamera arithmetic (libvox/src/render/esvo_raycast.cpp,
// CameraBasis) repeated expression for expression: same operations, same order, in double.
#include <vox/formats/error.h>
#include <vox/runtime/camera.h>

#include <cmath>

namespace vox::runtime {
namespace {
constexpr double kPi = 3.14159265358979323846;
Vec3d sub(const Vec3d& a, const Vec3d& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
double dot(const Vec3d& a, const Vec3d& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
double length(const Vec3d& a) { return std::sqrt(dot(a, a)); }
Vec3d cross(const Vec3d& a, const Vec3d& b) {
    return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
Vec3d normalize(const Vec3d& a) {
    const double len = length(a);
    return len > 0 ? Vec3d{a[0] / len, a[1] / len, a[2] / len} : Vec3d{0, 0, 0};
}
}  // namespace

void Camera::validate() const {
    const Vec3d forward = sub(target, eye);
    if (length(forward) == 0) throw UsageError("camera: --eye and --target are the same point");
    if (length(cross(forward, up)) <= 1e-12 * length(forward) * length(up))
        throw UsageError("camera: --up is parallel to the view direction");
    if (!(fovYDegrees > 0 && fovYDegrees < 180))
        throw UsageError("camera: --fov must be between 0 and 180 degrees");
    if (width < 1 || height < 1 || width > 16384 || height > 16384)
        throw UsageError("camera: image size must be 1..16384");
}

double Camera::pixelAngle() const {
    return 2.0 * std::tan(fovYDegrees * 0.5 * kPi / 180.0) / height;
}

Vec3d Camera::rayDirection(int x, int y) const { return CameraBasis(*this).direction(x, y); }

CameraBasis::CameraBasis(const Camera& c)
    : eye(c.eye),
      forward(normalize(sub(c.target, c.eye))),
      right(normalize(cross(forward, c.up))),
      up(cross(right, forward)),
      tanHalf(std::tan(c.fovYDegrees * 0.5 * kPi / 180.0)),
      aspect(double(c.width) / double(c.height)),
      width(c.width),
      height(c.height) {}

Vec3d CameraBasis::direction(int x, int y) const {
    const double px = x + 0.5, py = y + 0.5;
    const double sx = (px / width * 2.0 - 1.0) * tanHalf * aspect;
    const double sy = (1.0 - py / height * 2.0) * tanHalf;
    // forward + right·sx + up·sy, summed left to right as Vec3's operators do.
    const Vec3d v{forward[0] + right[0] * sx + up[0] * sy, forward[1] + right[1] * sx + up[1] * sy,
                  forward[2] + right[2] * sx + up[2] * sy};
    return normalize(v);
}

}  // namespace vox::runtime
