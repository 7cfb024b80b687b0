#include <vox/base/error.h>
#include <vox/texture.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace vox {
namespace {

const std::array<float, 256>& srgbDecodeTable() {
    static const std::array<float, 256> table = [] {
        std::array<float, 256> t{};
        for (int i = 0; i < 256; ++i) t[i] = srgbToLinear(static_cast<float>(i) / 255.0f);
        return t;
    }();
    return table;
}

std::uint8_t quantize(float value) {
    return static_cast<std::uint8_t>(std::lround(std::clamp(value, 0.0f, 1.0f) * 255.0f));
}

int wrapIndex(int i, int n, WrapMode mode) {
    // Inside the image every mode is the identity, and the divisions below cost as much as the
    // texel itself (Texture::integrate looks up several per fragment).
    if (static_cast<unsigned>(i) < static_cast<unsigned>(n)) return i;
    switch (mode) {
        case WrapMode::ClampToEdge:
            return std::clamp(i, 0, n - 1);
        case WrapMode::MirroredRepeat: {
            const int period = 2 * n;
            const int m = ((i % period) + period) % period;
            return m < n ? m : period - 1 - m;
        }
        case WrapMode::Repeat:
        default:
            return ((i % n) + n) % n;
    }
}

/// Brings a coordinate into a small range with the same wrapped result, so that huge UVs
/// neither overflow the integer texel index nor lose the fraction.
float reduceCoordinate(float u, WrapMode mode) {
    if (!std::isfinite(u)) return 0.0f;
    switch (mode) {
        case WrapMode::ClampToEdge:
            return std::clamp(u, -1.0f, 2.0f);
        case WrapMode::MirroredRepeat:
            return u - 2.0f * std::floor(u * 0.5f);
        case WrapMode::Repeat:
        default:
            return u - std::floor(u);
    }
}

/// Box-filters one axis of a linear float image from @p srcLen to @p dstLen texels, weighting
/// each source texel by how much of it the destination texel covers (exact for odd sizes).
std::vector<float> downsampleAxis(const std::vector<float>& src, int width, int height, bool alongX,
                                  int dstLen) {
    const int srcLen = alongX ? width : height;
    const int outW = alongX ? dstLen : width, outH = alongX ? height : dstLen;
    std::vector<float> dst(static_cast<std::size_t>(outW) * outH * 4, 0.0f);
    const double scale = static_cast<double>(srcLen) / dstLen;
    for (int d = 0; d < dstLen; ++d) {
        const double a = d * scale, b = (d + 1) * scale;
        for (int s = static_cast<int>(std::floor(a));
             s < std::min(srcLen, static_cast<int>(std::ceil(b))); ++s) {
            const float w = static_cast<float>(
                (std::min(b, s + 1.0) - std::max(a, static_cast<double>(s))) / scale);
            if (w <= 0) continue;
            const int lines = alongX ? height : width;
            for (int line = 0; line < lines; ++line) {
                const std::size_t si = alongX ? (static_cast<std::size_t>(line) * width + s)
                                              : (static_cast<std::size_t>(s) * width + line);
                const std::size_t di = alongX ? (static_cast<std::size_t>(line) * outW + d)
                                              : (static_cast<std::size_t>(d) * outW + line);
                for (int c = 0; c < 4; ++c) dst[di * 4 + c] += w * src[si * 4 + c];
            }
        }
    }
    return dst;
}

}  // namespace

Texture::Texture(std::string name, int width, int height, int channels,
                 std::span<const std::uint8_t> pixels, ColorSpace colorSpace)
    : name_(std::move(name)), colorSpace_(colorSpace), sourceChannels_(channels) {
    if (width < 1 || height < 1 || width > kMaxDimension || height > kMaxDimension)
        throw std::invalid_argument("Texture: size out of range");
    if (channels < 1 || channels > 4) throw std::invalid_argument("Texture: channels must be 1-4");
    const std::size_t texels = static_cast<std::size_t>(width) * height;
    if (pixels.size() != texels * channels)
        throw std::invalid_argument("Texture: pixel buffer size mismatch");

    Level base{width, height, std::vector<std::uint8_t>(texels * 4)};
    for (std::size_t i = 0; i < texels; ++i) {
        const std::uint8_t* p = pixels.data() + i * channels;
        std::uint8_t* q = base.rgba.data() + i * 4;
        switch (channels) {
            case 1:
                q[0] = q[1] = q[2] = p[0];
                q[3] = 255;
                break;
            case 2:
                q[0] = q[1] = q[2] = p[0];
                q[3] = p[1];
                break;
            case 3:
                q[0] = p[0];
                q[1] = p[1];
                q[2] = p[2];
                q[3] = 255;
                break;
            default:
                q[0] = p[0];
                q[1] = p[1];
                q[2] = p[2];
                q[3] = p[3];
                break;
        }
    }
    levels_.push_back(std::move(base));

    // The chain is filtered in linear float so rounding does not accumulate level to level.
    std::vector<float> linear(texels * 4);
    for (std::size_t i = 0; i < texels; ++i) {
        const Vec4f v = decode(levels_[0].rgba.data() + i * 4);
        for (int c = 0; c < 4; ++c) linear[i * 4 + c] = v[c];
    }
    int w = width, h = height;
    while (w > 1 || h > 1) {
        const int nw = std::max(1, w / 2), nh = std::max(1, h / 2);
        if (nw != w) linear = downsampleAxis(linear, w, h, true, nw);
        if (nh != h) linear = downsampleAxis(linear, nw, h, false, nh);
        w = nw;
        h = nh;
        Level level{w, h, std::vector<std::uint8_t>(static_cast<std::size_t>(w) * h * 4)};
        for (std::size_t i = 0; i < static_cast<std::size_t>(w) * h; ++i) {
            for (int c = 0; c < 3; ++c) {
                const float v = linear[i * 4 + c];
                level.rgba[i * 4 + c] =
                    quantize(colorSpace_ == ColorSpace::SRGB ? linearToSrgb(v) : v);
            }
            level.rgba[i * 4 + 3] = quantize(linear[i * 4 + 3]);
        }
        levels_.push_back(std::move(level));
    }
}

std::size_t Texture::memoryBytes() const noexcept {
    std::size_t bytes = 0;
    for (const Level& level : levels_) bytes += level.rgba.size();
    return bytes;
}

namespace {

/// An RGBA8 texel as linear floats: colour through @p srgb (srgbDecodeTable) where the texture is
/// sRGB (null where linear), alpha always linear. Inline, so that a loop over texels can look the
/// table up once (as a call, the returned vector also went through memory on every texel).
inline Vec4f decodeTexel(const std::uint8_t* p, const float* srgb) {
    constexpr float inv = 1.0f / 255.0f;
    if (srgb) return {srgb[p[0]], srgb[p[1]], srgb[p[2]], p[3] * inv};
    return {p[0] * inv, p[1] * inv, p[2] * inv, p[3] * inv};
}

}  // namespace

Vec4f Texture::decode(const std::uint8_t* p) const {
    return decodeTexel(p, colorSpace_ == ColorSpace::SRGB ? srgbDecodeTable().data() : nullptr);
}

Vec4f Texture::texel(int level, int x, int y) const {
    const Level& l = levels_.at(level);
    if (x < 0 || y < 0 || x >= l.width || y >= l.height) throw std::out_of_range("Texture::texel");
    return decode(l.rgba.data() + (static_cast<std::size_t>(y) * l.width + x) * 4);
}

Vec4f Texture::bilinear(const Level& level, Vec2f uv, WrapMode wrapS, WrapMode wrapT) const {
    const float x = reduceCoordinate(uv.x, wrapS) * level.width - 0.5f;
    const float y = reduceCoordinate(uv.y, wrapT) * level.height - 0.5f;
    const float fx0 = std::floor(x), fy0 = std::floor(y);
    const float tx = x - fx0, ty = y - fy0;
    const int x0 = static_cast<int>(fx0), y0 = static_cast<int>(fy0);
    const int xs[2] = {wrapIndex(x0, level.width, wrapS), wrapIndex(x0 + 1, level.width, wrapS)};
    const int ys[2] = {wrapIndex(y0, level.height, wrapT), wrapIndex(y0 + 1, level.height, wrapT)};
    auto at = [&](int xi, int yi) {
        return decode(level.rgba.data() +
                      (static_cast<std::size_t>(ys[yi]) * level.width + xs[xi]) * 4);
    };
    return (at(0, 0) * (1 - tx) + at(1, 0) * tx) * (1 - ty) +
           (at(0, 1) * (1 - tx) + at(1, 1) * tx) * ty;
}

Vec4f Texture::sample(Vec2f uv, float footprint, WrapMode wrapS, WrapMode wrapT) const {
    if (levels_.empty()) return {1, 1, 1, 1};
    const float texels = std::isfinite(footprint)
                             ? footprint * static_cast<float>(std::max(width(), height()))
                             : 0.0f;
    const float lod = std::clamp(texels > 1.0f ? std::log2(texels) : 0.0f, 0.0f,
                                 static_cast<float>(levelCount() - 1));
    const int fine = static_cast<int>(lod);
    const float t = lod - static_cast<float>(fine);
    const Vec4f a = bilinear(levels_[fine], uv, wrapS, wrapT);
    if (t <= 0.0f || fine + 1 >= levelCount()) return a;
    const Vec4f b = bilinear(levels_[fine + 1], uv, wrapS, wrapT);
    return a * (1 - t) + b * t;
}

namespace {

/// The area of a polygon inside each cell of a grid of unit cells (texels), from its edges alone,
/// as exact-area scanline rasterisers find coverage: by Green's theorem the area inside column
/// [c, c + 1] is the sum over the edges of ∫ clamp(x(y) − c, 0, 1) dy (dy signed; positive for a
/// counterclockwise polygon), so an edge adds, within each row it crosses, the trapezoid between
/// itself and the left side of each cell it passes through, and its full height to every cell
/// left of those (summed along the row at the end). Each edge is cut once per row and column line
/// it crosses, instead of the polygon once per line with a copy of the rest. Coordinates are
/// relative to the grid's corner (so within [0, width] × [0, height] up to rounding, what leaves
/// the grid by rounding counts in its nearest cell), in double: the products of absolute texel
/// coordinates in float, as the shoelace formula takes them, lose the areas of small pieces.
class CellCoverage {
public:
    static constexpr int kMaxCells = 40;  ///< per axis; integrate's levels keep polygons within 34

    /// Cells [0, width) × [0, height), all empty.
    CellCoverage(int width, int height) : width_(width), height_(height) {
        std::fill_n(area_.begin(), static_cast<std::size_t>(width * height), 0.0);
        std::fill_n(cover_.begin(), static_cast<std::size_t>(width * height), 0.0);
    }

    /// Adds the edge from (@p px, @p py) to (@p qx, @p qy).
    void addEdge(double px, double py, double qx, double qy) {
        if (py == qy) return;  // horizontal: no height
        const double sign = py < qy ? 1.0 : -1.0;
        if (py > qy) {
            std::swap(px, qx);
            std::swap(py, qy);
        }
        const double slope = (qx - px) / (qy - py);
        const int end = std::min(ceiling(qy), height_);
        double ys = py, xs = px;
        for (int row = cell(py, height_); row < end; ++row) {
            const double ye = std::min(qy, double(row + 1));
            const double xe = ye == qy ? qx : px + (ye - py) * slope;
            if (ye > ys) addRowSegment(row, std::min(xs, xe), std::max(xs, xe), sign * (ye - ys));
            ys = ye;
            xs = xe;
        }
    }

    /// After the last edge: each cell's signed area (counterclockwise positive).
    void finish() {
        for (int row = 0; row < height_; ++row) {
            double* area = &area_[static_cast<std::size_t>(row * width_)];
            const double* cover = &cover_[static_cast<std::size_t>(row * width_)];
            double right = 0;  // the heights of the edge pieces right of the cell
            for (int c = width_ - 1; c >= 0; --c) {
                area[c] += right;
                right += cover[c];
            }
        }
    }
    [[nodiscard]] double area(int column, int row) const {
        return area_[static_cast<std::size_t>(row * width_ + column)];
    }

private:
    /// The cell of coordinate @p v ≥ 0 (its integer part; 0 below, by rounding), at most @p count
    /// − 1.
    static int cell(double v, int count) {
        return std::min(static_cast<int>(std::max(v, 0.0)), count - 1);
    }
    /// ⌈v⌉ for v ≥ 0.
    static int ceiling(double v) {
        const int whole = static_cast<int>(std::max(v, 0.0));
        return whole + (v > whole ? 1 : 0);
    }

    /// A piece of an edge within one row, spanning x from @p lo to @p hi while rising @p height
    /// (signed): per column it passes, the trapezoid to the column's left side and its height.
    void addRowSegment(int row, double lo, double hi, double height) {
        double* area = &area_[static_cast<std::size_t>(row * width_)];
        double* cover = &cover_[static_cast<std::size_t>(row * width_)];
        const int first = cell(lo, width_),
                  last = std::max(std::min(ceiling(hi), width_) - 1, first);
        if (first == last) {
            area[first] += height * (0.5 * (lo + hi) - first);
            cover[first] += height;
            return;
        }
        // Across columns the edge rises in proportion to x: its first and last columns hold what
        // it crosses of them, the ones between a whole unit each.
        const double perX = height / (hi - lo);
        const double enter = (first + 1 - lo) * perX, leave = (hi - last) * perX;
        area[first] += enter * 0.5 * (lo - first + 1);
        cover[first] += enter;
        for (int c = first + 1; c < last; ++c) {
            area[c] += 0.5 * perX;
            cover[c] += perX;
        }
        area[last] += leave * 0.5 * (hi - last);
        cover[last] += leave;
    }

    int width_, height_;
    std::array<double, kMaxCells * kMaxCells>
        area_;  // per cell; until finish(), without the heights from the right
    std::array<double, kMaxCells * kMaxCells>
        cover_;  // per cell: the heights of the edge pieces in it
};

}  // namespace

Vec4f Texture::integrate(std::span<const Vec2f> polygon, WrapMode wrapS, WrapMode wrapT,
                         int maxTexels, Vec4f* meanSquare) const {
    // A single value: its square is the mean square.
    const auto single = [&](Vec4f v) {
        if (meanSquare) *meanSquare = {v.x * v.x, v.y * v.y, v.z * v.z, v.w * v.w};
        return v;
    };
    if (levels_.empty()) return single({1, 1, 1, 1});
    if (polygon.empty()) return single(sample({0, 0}, 0, wrapS, wrapT));
    Vec2f lo = polygon[0], hi = polygon[0], mean{0, 0};
    for (const Vec2f& p : polygon) {
        lo = {std::min(lo.x, p.x), std::min(lo.y, p.y)};
        hi = {std::max(hi.x, p.x), std::max(hi.y, p.y)};
        mean = mean + p * (1.0f / static_cast<float>(polygon.size()));
    }
    if (!(std::isfinite(lo.x) && std::isfinite(lo.y) && std::isfinite(hi.x) && std::isfinite(hi.y)))
        return single(sample(mean, 0, wrapS, wrapT));
    int level = 0;
    const auto span = [&](int l) {
        return std::max(double(hi.x - lo.x) * levels_[l].width,
                        double(hi.y - lo.y) * levels_[l].height);
    };
    while (level + 1 < levelCount() && span(level) > maxTexels) ++level;
    if (span(level) > 4.0 * maxTexels)
        return single(texel(level, 0, 0));  // the 1×1 level: the image's mean
    const Level& l = levels_[level];
    // Texel indices beyond float's integers (2^24) are neither exact nor within int: a polygon that
    // far out (huge but finite UVs) is point-sampled at its mean, which sample() wraps first.
    const double reach = std::max({std::fabs(double(lo.x)), std::fabs(double(hi.x))}) * l.width +
                         std::max({std::fabs(double(lo.y)), std::fabs(double(hi.y))}) * l.height;
    if (reach > 16777216.0) return single(sample(mean, 0, wrapS, wrapT));

    const int x0 = static_cast<int>(std::floor(lo.x * l.width)),
              x1 = std::max(static_cast<int>(std::ceil(hi.x * l.width)), x0 + 1);
    const int y0 = static_cast<int>(std::floor(lo.y * l.height)),
              y1 = std::max(static_cast<int>(std::ceil(hi.y * l.height)), y0 + 1);
    const float* srgb = colorSpace_ == ColorSpace::SRGB ? srgbDecodeTable().data() : nullptr;
    const auto texelAt = [&](int x, int y) {
        const int tx = wrapIndex(x, l.width, wrapS), ty = wrapIndex(y, l.height, wrapT);
        return decodeTexel(l.rgba.data() + (static_cast<std::size_t>(ty) * l.width + tx) * 4, srgb);
    };
    // The polygon in texel units relative to the grid's corner (double: float products of absolute
    // texel coordinates, as the shoelace formula takes them, are too coarse for a texel's area);
    // a triangle clipped to a cube has at most 9 vertices.
    struct Point {
        double x, y;
    };
    std::array<Point, 12> points;
    const std::size_t n = std::min<std::size_t>(polygon.size(), points.size());
    double twiceArea = 0;  // signed: the polygon's orientation
    for (std::size_t i = 0; i < n; ++i)
        points[i] = {double(polygon[i].x * static_cast<float>(l.width)) - x0,
                     double(polygon[i].y * static_cast<float>(l.height)) - y0};
    for (std::size_t i = 0; i < n; ++i) {
        const Point p = points[i], q = points[i + 1 == n ? 0 : i + 1];
        twiceArea += p.x * q.y - q.x * p.y;
    }
    // Most fragments of a fine voxelization lie within one texel: its value, where the polygon has
    // area.
    if (x1 == x0 + 1 && y1 == y0 + 1)
        return single(twiceArea != 0 ? texelAt(x0, y0) : sample(mean, 0, wrapS, wrapT));
    if (x1 - x0 > CellCoverage::kMaxCells || y1 - y0 > CellCoverage::kMaxCells)
        return single(sample(mean, 0, wrapS, wrapT));  // unreachable (see above)

    // Otherwise the texels weigh by the areas of the polygon inside them.
    const int width = x1 - x0, height = y1 - y0;
    CellCoverage coverage(width, height);
    for (std::size_t i = 0; i < n; ++i) {
        const Point p = points[i], q = points[i + 1 == n ? 0 : i + 1];
        coverage.addEdge(p.x, p.y, q.x, q.y);
    }
    coverage.finish();
    const double orientation = twiceArea < 0 ? -1.0 : 1.0;
    Vec4f sum{0, 0, 0, 0}, squares{0, 0, 0, 0};
    float total = 0;
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
            const auto area = static_cast<float>(orientation * coverage.area(x, y));
            if (!(area > 0)) continue;
            const Vec4f v = texelAt(x0 + x, y0 + y);
            sum = sum + v * area;
            if (meanSquare)
                squares = squares + Vec4f{v.x * v.x, v.y * v.y, v.z * v.z, v.w * v.w} * area;
            total += area;
        }
    if (!(total > 0)) return single(sample(mean, 0, wrapS, wrapT));
    if (meanSquare) *meanSquare = squares * (1.0f / total);
    return sum * (1.0f / total);
}

}  // namespace vox
