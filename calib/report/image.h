// An 8-bit RGB raster and its encoders: PNG file bytes (through cairo, which
// writes with libpng) and base64 data URIs, so a report embeds images in one
// self-contained HTML file.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

namespace calib::report {

struct Color {
    std::uint8_t r = 0, g = 0, b = 0;
    friend bool operator==(const Color &, const Color &) = default;
};

// Row-major, top row first, three bytes per pixel.
struct Image {
    int width = 0, height = 0;
    std::vector<std::uint8_t> rgb;

    Color at(int x, int y) const
    {
        const std::uint8_t *p =
            &rgb[(static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x)) * 3];
        return {p[0], p[1], p[2]};
    }
};

// PNG file bytes (8-bit RGB). std::invalid_argument for an empty image or a
// buffer that does not match the size, std::runtime_error if encoding fails.
std::vector<std::uint8_t> encode_png(const Image &img);
std::string base64(const std::vector<std::uint8_t> &bytes);
// "data:image/png;base64,..." for an <img src>.
std::string png_data_uri(const Image &img);

} // namespace calib::report
