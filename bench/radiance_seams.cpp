// Seams of a tiled radiance bake: a tiled volume (tile index) against a single-volume bake of the
// same scene and depth, cell by cell at level 0. Prints, as JSON, the mean relative difference of
// the cells' radiance (emission + albedo/π · irradiance: at a fixed albedo, the irradiance's) over
// every cell solid in both, and over those within 2 cells of a tile border.
//
//   radiance_seams SINGLE.rvol TILED.rvol
#include <vox/formats/rvol_io.h>
#include <vox/formats/rvol_tiles.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <iostream>

int main(int argc, char** argv) {
    if (argc != 3) {
        std::fprintf(stderr, "usage: radiance_seams SINGLE.rvol TILED.rvol\n");
        return 1;
    }
    try {
        const vox::rvol::RvolReader single(argv[1]);
        const vox::rvol::TiledRvolReader tiled(argv[2]);
        const vox::rvol::TileIndex& index = tiled.index();
        if (single.header().depth != index.depth || single.header().size != index.size)
            throw std::runtime_error("the two volumes differ in depth or root cube");
        const std::uint32_t tile = 1u << index.tileDepth;
        // Luminance of a texel's radiance (un-premultiplied; level-0 opacity is 0 or 1).
        const auto luminance = [](const vox::rvol::Texel& t) {
            return 0.2126 * t.r + 0.7152 * t.g + 0.0722 * t.b;
        };
        double sum = 0, sumBorder = 0, sumSingle = 0;
        std::uint64_t cells = 0, border = 0, missing = 0;
        const double cs = single.header().cellSize(0);
        const auto& o = single.header().origin;
        std::vector<std::pair<double, double>> values;  // (single, tiled) per cell
        std::vector<bool> nearBorder;
        for (const vox::rvol::VoxelAttributes& v : single.readAttributes(false)) {
            const vox::rvol::Texel a = single.sample(
                0, 0, {o[0] + (v.x + 0.5) * cs, o[1] + (v.y + 0.5) * cs, o[2] + (v.z + 0.5) * cs});
            const vox::rvol::Texel b = tiled.cell(0, 0, v.x, v.y, v.z);
            if (b.a <= 0) {
                ++missing;
                continue;
            }
            values.emplace_back(luminance(a), luminance(b));
            sumSingle += luminance(a);
            bool edge = false;
            for (std::uint32_t c : {v.x, v.y, v.z})
                edge = edge || c % tile < 2 || c % tile >= tile - 2;
            nearBorder.push_back(edge);
        }
        // Relative to each cell's own value, with a floor of 1 % of the mean so that black cells
        // (radiance ≈ 0 in both) do not divide by zero.
        const double floor = values.empty() ? 0 : 0.01 * sumSingle / double(values.size());
        for (std::size_t i = 0; i < values.size(); ++i) {
            const double d =
                std::abs(values[i].second - values[i].first) / std::max(values[i].first, floor);
            sum += d;
            ++cells;
            if (nearBorder[i]) {
                sumBorder += d;
                ++border;
            }
        }
        const nlohmann::json out{
            {"depth", index.depth},
            {"tile_depth", index.tileDepth},
            {"halo", index.halo},
            {"far_depth", index.farDepth},
            {"tiles", index.tiles.size()},
            {"cells", cells},
            {"cells_missing_in_tiled", missing},
            {"border_cells", border},
            {"mean_relative_difference", cells ? sum / double(cells) : 0.0},
            {"mean_relative_difference_border", border ? sumBorder / double(border) : 0.0}};
        std::cout << out.dump(2) << "\n";
    } catch (const std::exception& e) {
        std::fprintf(stderr, "radiance_seams: error: %s\n", e.what());
        return 3;
    }
    return 0;
}
