#include "report/modes_section.h"

#include "io/format.h"
#include "report/image.h"
#include "report/mode_image.h"

#include <algorithm>
#include <cstdint>
#include <sstream>

namespace calib::report {

std::string modes_html(const engine::PlateModes &m, const engine::PlateOperator &op, int images)
{
    const engine::Grid &g = op.grid();
    std::ostringstream h;
    h << "<h2>Plate modes</h2><p>The " << m.frequency_hz.size()
      << " lowest eigenmodes of the Kirchhoff plate on the calibration grid (engine/modes.h: shift-invert "
         "Lanczos on the assembled operator; the scene's thick-plate, finger and exciter effects are not in them). "
         "A drive band that holds only a few modes focuses poorly: time reversal needs many modes in the pulse's "
         "band.</p><table><tr><th>mode</th><th>frequency (Hz)</th><th>T60 (s)</th><th>x symmetry</th>"
         "<th>y symmetry</th></tr>";
    for (std::size_t i = 0; i < m.frequency_hz.size(); ++i)
        h << "<tr><td>" << i + 1 << "</td><td>" << io::fmt("%.2f", m.frequency_hz[i]) << "</td><td>"
          << (m.decay_rate_1_s[i] > 0 ? io::fmt("%.3g", engine::t60_of_decay_rate_s(m.decay_rate_1_s[i]))
                                      : std::string("-"))
          << "</td><td>" << engine::parity_name(m.parity_x[i]) << "</td><td>" << engine::parity_name(m.parity_y[i])
          << "</td></tr>";
    h << "</table><div class='grid'>";
    const int shown = std::min<int>(images, int(m.frequency_hz.size()));
    for (int c = 0; c < shown; ++c)
        h << "<figure class='cell'><img alt='mode " << c + 1 << "' src='"
          << png_data_uri(mode_shape_image(engine::mode_field(op, m.shapes.col(c)), g.nx + 1, g.ny + 1, 200))
          << "'><figcaption>mode " << c + 1 << ", " << io::fmt("%.2f Hz", m.frequency_hz[std::size_t(c)])
          << " (red +, blue -, white: nodal lines)</figcaption></figure>";
    h << "</div>";
    return h.str();
}

toml::array modes_json(const engine::PlateModes &m)
{
    toml::array out;
    for (std::size_t i = 0; i < m.frequency_hz.size(); ++i) {
        toml::table t{{"mode", static_cast<std::int64_t>(i + 1)},
                      {"frequency_hz", m.frequency_hz[i]},
                      {"decay_rate_1_s", m.decay_rate_1_s[i]},
                      {"x_symmetry", engine::parity_name(m.parity_x[i])},
                      {"y_symmetry", engine::parity_name(m.parity_y[i])}};
        if (m.decay_rate_1_s[i] > 0)
            t.insert("t60_s", engine::t60_of_decay_rate_s(m.decay_rate_1_s[i]));
        out.push_back(std::move(t));
    }
    return out;
}

} // namespace calib::report
