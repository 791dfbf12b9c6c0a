// Several field images at once, and the field over time as an HTML fragment:
// one <img> per frame (PNG data URIs), all but the shown one hidden, and a
// slider and a play button wired by a few lines of inline script. Without
// script the first frame still shows.
#include "report/canvas.h"
#include "report/field_image.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <exception>
#include <stdexcept>

namespace calib::report {

namespace {

bool valid_id(const std::string &id)
{
    if (id.empty() || !std::isalpha(static_cast<unsigned char>(id[0])))
        return false;
    return std::all_of(id.begin(), id.end(),
                       [](char ch) { return std::isalnum(static_cast<unsigned char>(ch)) || ch == '-' || ch == '_'; });
}

// Enough decimals in ms to tell neighbouring frames apart.
std::vector<std::string> time_labels(const std::vector<double> &t)
{
    double step = INFINITY;
    for (std::size_t k = 1; k < t.size(); ++k)
        if (t[k] != t[k - 1])
            step = std::min(step, std::abs(t[k] - t[k - 1]));
    const int decimals =
        std::isfinite(step) ? std::clamp(static_cast<int>(std::ceil(-std::log10(step * 1e3))), 0, 4) : 1;
    std::vector<std::string> out;
    for (double v : t) {
        char buf[48];
        std::snprintf(buf, sizeof buf, "t = %.*f ms", decimals, v * 1e3);
        out.push_back(buf);
    }
    return out;
}

} // namespace

std::vector<std::string> render_field_uris(const std::vector<FieldMap> &fields, const std::vector<FieldStyle> &styles)
{
    if (styles.size() != 1 && styles.size() != fields.size())
        throw std::invalid_argument("field images: " + std::to_string(fields.size()) + " fields but " +
                                    std::to_string(styles.size()) + " styles");
    std::vector<std::string> uris(fields.size());
    std::exception_ptr error;
#pragma omp parallel for schedule(dynamic)
    for (std::size_t k = 0; k < fields.size(); ++k) {
        try {
            uris[k] = png_data_uri(render_field(fields[k], styles[styles.size() == 1 ? 0 : k]));
        } catch (...) {
#pragma omp critical
            error = std::current_exception();
        }
    }
    if (error)
        std::rethrow_exception(error);
    return uris;
}

std::string field_movie_html(const std::vector<FieldMap> &frames, const std::vector<double> &times_s,
                             const FieldStyle &style, const std::string &element_id)
{
    if (frames.empty())
        throw std::invalid_argument("field movie: no frames");
    if (frames.size() != times_s.size())
        throw std::invalid_argument("field movie: " + std::to_string(frames.size()) + " frames but " +
                                    std::to_string(times_s.size()) + " times");
    if (!valid_id(element_id))
        throw std::invalid_argument("field movie: element id '" + element_id +
                                    "' must be a letter followed by letters, digits, '-' or '_'");
    for (std::size_t k = 0; k < frames.size(); ++k) {
        const FieldMap &a = frames[0], &b = frames[k];
        if (b.nx != a.nx || b.ny != a.ny || b.x0_m != a.x0_m || b.y0_m != a.y0_m || b.dx_m != a.dx_m ||
            b.dy_m != a.dy_m)
            throw std::invalid_argument("field movie: frame " + std::to_string(k) +
                                        " is on another lattice than frame 0");
        if (!std::isfinite(times_s[k]))
            throw std::invalid_argument("field movie: time of frame " + std::to_string(k) + " is not finite");
    }
    // One colour scale for every frame, so a colour means the same displacement throughout.
    FieldStyle shared = style;
    if (!shared.vmax) {
        double top = -INFINITY;
        for (const FieldMap &f : frames)
            for (float v : f.value)
                if (std::isfinite(v))
                    top = std::max(top, static_cast<double>(v));
        if (std::isfinite(top) && top > shared.vmin.value_or(0.0))
            shared.vmax = top;
    }
    field_layout(frames[0], shared); // refuses a bad style or lattice before any work

    const std::vector<std::string> labels = time_labels(times_s);
    const std::vector<std::string> uris = render_field_uris(frames, {shared});

    const std::string alt = canvas::xml_escape(style.title.empty() ? "field" : style.title);
    std::string h = "<div class=\"field-movie\" id=\"" + element_id + "\">\n";
    for (std::size_t k = 0; k < frames.size(); ++k)
        h += "<img src=\"" + uris[k] + "\" alt=\"" + alt + ", " + labels[k] + "\" data-t=\"" + labels[k] + "\"" +
             (k ? " hidden=\"hidden\"" : "") + "/>\n";
    h += "<div><button type=\"button\">play</button> <input type=\"range\" min=\"0\" max=\"" +
         std::to_string(frames.size() - 1) + "\" step=\"1\" value=\"0\" aria-label=\"frame\"/> <span>" + labels[0] +
         "</span></div>\n";
    // No '<', '>' or '&' in the script: the fragment stays well-formed XML too.
    h += "<script>(function () {\n"
         "var root = document.getElementById('" +
         element_id +
         "');\n"
         "var frames = root.querySelectorAll('img'), slider = root.querySelector('input');\n"
         "var button = root.querySelector('button'), label = root.querySelector('span'), timer = null;\n"
         "function show(k) {\n"
         "  frames.forEach(function (f, i) { f.hidden = i !== k; });\n"
         "  slider.value = k; label.textContent = frames[k].dataset.t;\n"
         "}\n"
         "function stop() { clearInterval(timer); timer = null; button.textContent = 'play'; }\n"
         "slider.addEventListener('input', function () { stop(); show(Number(slider.value)); });\n"
         "button.addEventListener('click', function () {\n"
         "  if (timer) { stop(); return; }\n"
         "  button.textContent = 'pause';\n"
         "  timer = setInterval(function () { show((Number(slider.value) + 1) % frames.length); }, 150);\n"
         "});\n"
         "})();</script>\n</div>\n";
    return h;
}

} // namespace calib::report
