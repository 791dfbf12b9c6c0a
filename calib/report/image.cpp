// PNG through cairo's image surface writer rather than a second encoder: the
// plots are drawn by cairo anyway, and libpng's deflate gives smaller data
// URIs than stb_image_write's.
#include "report/image.h"

#include <cairo.h>

#include <memory>
#include <stdexcept>

namespace calib::report {

namespace {

struct SurfaceFree {
    void operator()(cairo_surface_t *s) const { cairo_surface_destroy(s); }
};

cairo_status_t append(void *closure, const unsigned char *data, unsigned int length)
{
    auto *out = static_cast<std::vector<std::uint8_t> *>(closure);
    out->insert(out->end(), data, data + length);
    return CAIRO_STATUS_SUCCESS;
}

} // namespace

std::vector<std::uint8_t> encode_png(const Image &img)
{
    if (img.width <= 0 || img.height <= 0 ||
        img.rgb.size() != static_cast<std::size_t>(img.width) * static_cast<std::size_t>(img.height) * 3)
        throw std::invalid_argument("PNG: image size does not match its pixel buffer");
    std::unique_ptr<cairo_surface_t, SurfaceFree> s(
        cairo_image_surface_create(CAIRO_FORMAT_RGB24, img.width, img.height));
    if (cairo_surface_status(s.get()) != CAIRO_STATUS_SUCCESS)
        throw std::runtime_error(std::string("PNG: ") + cairo_status_to_string(cairo_surface_status(s.get())));
    cairo_surface_flush(s.get());
    unsigned char *base = cairo_image_surface_get_data(s.get());
    const int stride = cairo_image_surface_get_stride(s.get());
    for (int y = 0; y < img.height; ++y) {
        auto *row = reinterpret_cast<std::uint32_t *>(base + static_cast<std::ptrdiff_t>(y) * stride);
        for (int x = 0; x < img.width; ++x) {
            const Color c = img.at(x, y);
            row[x] = (std::uint32_t(c.r) << 16) | (std::uint32_t(c.g) << 8) | c.b; // RGB24: native-endian 0x00RRGGBB
        }
    }
    cairo_surface_mark_dirty(s.get());
    std::vector<std::uint8_t> out;
    const cairo_status_t st = cairo_surface_write_to_png_stream(s.get(), append, &out);
    if (st != CAIRO_STATUS_SUCCESS)
        throw std::runtime_error(std::string("PNG encoding failed: ") + cairo_status_to_string(st));
    return out;
}

std::string base64(const std::vector<std::uint8_t> &in)
{
    static const char *t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    out.reserve((in.size() + 2) / 3 * 4);
    for (std::size_t i = 0; i < in.size(); i += 3) {
        const std::uint32_t v = (std::uint32_t(in[i]) << 16) | (i + 1 < in.size() ? std::uint32_t(in[i + 1]) << 8 : 0) |
                                (i + 2 < in.size() ? std::uint32_t(in[i + 2]) : 0);
        out += t[(v >> 18) & 63];
        out += t[(v >> 12) & 63];
        out += i + 1 < in.size() ? t[(v >> 6) & 63] : '=';
        out += i + 2 < in.size() ? t[v & 63] : '=';
    }
    return out;
}

std::string png_data_uri(const Image &img) { return "data:image/png;base64," + base64(encode_png(img)); }

} // namespace calib::report
