#include "camera_options.h"

#include <vox/base/error.h>

#include <cmath>
#include <cstdio>

namespace vox::tools {

Vec3d parseVector(const std::string& text, const char* option) {
    if (const auto v = parseVec3(text)) return *v;
    throw UsageError(std::string(option) + " expects x,y,z (got '" + text + "')");
}

void CameraOptions::add(CLI::App& command) {
    command.add_option("--eye", eye, "Camera position x,y,z (world units)")->required();
    command.add_option("--target", target, "Point looked at x,y,z")->required();
    command.add_option("--up", up, "Up vector x,y,z")->capture_default_str();
    command.add_option("--fov", fov, "Vertical field of view, degrees")->capture_default_str();
    command.add_option("--width", width, "Image width")->capture_default_str();
    command.add_option("--height", height, "Image height")->capture_default_str();
}

PinholeCamera CameraOptions::camera() const {
    PinholeCamera camera;
    camera.eye = parseVector(eye, "--eye");
    camera.target = parseVector(target, "--target");
    camera.up = parseVector(up, "--up");
    camera.fovYDegrees = fov;
    camera.width = width;
    camera.height = height;
    camera.validate();
    return camera;
}

}  // namespace vox::tools
