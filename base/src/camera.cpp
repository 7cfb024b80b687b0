#include <vox/base/camera.h>
#include <vox/base/error.h>

#include <cmath>

namespace vox {
namespace {
constexpr double kPi = 3.14159265358979323846;
}

void PinholeCamera::validate() const {
    const Vec3d forward = target - eye;
    if (length(forward) == 0)
        throw ParameterError("eye", "is the same point as the camera's target");
    if (length(cross(forward, up)) <= 1e-12 * length(forward) * length(up))
        throw ParameterError("up", "is parallel to the view direction");
    if (!(fovYDegrees > 0 && fovYDegrees < 180))
        throw ParameterError("fovYDegrees", "must be between 0 and 180 degrees");
    if (width < 1 || height < 1 || width > 16384 || height > 16384)
        throw ParameterError("size", "must be 1..16384");
}

double PinholeCamera::pixelAngle() const {
    return 2.0 * std::tan(fovYDegrees * 0.5 * kPi / 180.0) / height;
}

Ray PinholeCamera::rayThrough(int x, int y) const { return CameraBasis(*this).ray(x, y); }

CameraBasis::CameraBasis(const PinholeCamera& c)
    : eye(c.eye),
      forward(normalize(c.target - c.eye)),
      right(normalize(cross(forward, c.up))),
      up(cross(right, forward)),
      tanHalf(std::tan(c.fovYDegrees * 0.5 * kPi / 180.0)),
      aspect(double(c.width) / double(c.height)),
      width(c.width),
      height(c.height) {}

Ray CameraBasis::rayAt(double px, double py) const {
    const double sx = (px / width * 2.0 - 1.0) * tanHalf * aspect;
    const double sy = (1.0 - py / height * 2.0) * tanHalf;
    return {eye, normalize(forward + right * sx + up * sy)};
}

}  // namespace vox
