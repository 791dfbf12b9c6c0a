#include "report/mode_image.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>

namespace calib::report {

Image mode_shape_image(const std::vector<double> &field, int nodes_x, int nodes_y, int target_px)
{
    const int px = std::max(1, target_px / std::max(nodes_x, nodes_y));
    Image img;
    img.width = nodes_x * px;
    img.height = nodes_y * px;
    img.rgb.resize(std::size_t(img.width) * std::size_t(img.height) * 3);
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            const int i = x / px, j = nodes_y - 1 - y / px;
            const double v = std::clamp(field[std::size_t(j) * std::size_t(nodes_x) + std::size_t(i)], -1.0, 1.0);
            const double fade = 1 - std::abs(v); // white at 0
            const Color full = v >= 0 ? Color{178, 24, 43} : Color{33, 102, 172};
            std::uint8_t *p = &img.rgb[(std::size_t(y) * std::size_t(img.width) + std::size_t(x)) * 3];
            p[0] = std::uint8_t(std::lround(full.r + fade * (255 - full.r)));
            p[1] = std::uint8_t(std::lround(full.g + fade * (255 - full.g)));
            p[2] = std::uint8_t(std::lround(full.b + fade * (255 - full.b)));
        }
    return img;
}

} // namespace calib::report
