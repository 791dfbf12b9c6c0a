#include "study/sweep.h"

#include "io/read_file.h"
#include "scene/toml_fields.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

namespace calib::study {

namespace {

struct AxisInfo {
    AxisKind kind;
    const char *name;
    const char *section; // scene table
    const char *key;     // scene key
    enum { integer, number, string, edges } type;
};

constexpr AxisInfo axis_table[] = {
    {AxisKind::exciter_count, "exciter_count", "exciters", "count", AxisInfo::integer},
    {AxisKind::material, "material", "plate", "material", AxisInfo::string},
    {AxisKind::thickness_m, "thickness_m", "plate", "thickness_m", AxisInfo::number},
    {AxisKind::pulse_centre_hz, "pulse_centre_hz", "pulse", "centre_hz", AxisInfo::number},
    {AxisKind::pulse_cycles, "pulse_cycles", "pulse", "cycles", AxisInfo::number},
    {AxisKind::edges, "edges", "plate", "edges", AxisInfo::edges},
    {AxisKind::placement_criterion, "placement_criterion", "exciters", "criterion", AxisInfo::string},
    {AxisKind::seed, "seed", "exciters", "seed", AxisInfo::integer},
};

const AxisInfo &info(AxisKind k)
{
    for (const AxisInfo &a : axis_table)
        if (a.kind == k)
            return a;
    throw std::logic_error("sweep: axis without an entry");
}

const char *type_name(const toml::node &n) { return toml::impl::node_type_friendly_names[unsigned(n.type())].data(); }

// A scene stays far below this many cases in any sane study; the bound keeps
// a typo ("to = 1e9") from allocating forever.
constexpr double max_range_values = 100000;

// {from, to, step}: to inclusive (within a millionth of a step, so 0.1 steps
// reach their end despite rounding); values computed as from + i step.
toml::array expand_range(const scene::Fields &r, const AxisInfo &a)
{
    const bool integral = a.type == AxisInfo::integer;
    auto get = [&](const char *key, std::optional<double> fallback) -> double {
        if (!r.has(key)) {
            if (fallback)
                return *fallback;
            r.fail(key, "missing (required in a range {from, to, step})");
        }
        const toml::node &n = *r.node(key);
        if (integral && !n.is_integer())
            r.fail(key, std::string("must be an integer, got ") + type_name(n));
        const double v = r.required_number(key);
        if (!std::isfinite(v))
            r.fail(key, "must be finite");
        return v;
    };
    const double from = get("from", std::nullopt), to = get("to", std::nullopt);
    const double step = get("step", integral ? std::optional<double>(1.0) : std::nullopt);
    if (!(step > 0))
        r.fail("step", "must be > 0, got " + scene::format_number(step));
    if (to < from)
        r.fail("to",
               "empty range: to (" + scene::format_number(to) + ") is below from (" + scene::format_number(from) + ")");
    const double n = std::floor((to - from) / step + 1e-6) + 1;
    if (n > max_range_values)
        r.fail("step", "range of " + scene::format_number(n) + " values (at most " +
                           scene::format_number(max_range_values) + ")");
    toml::array out;
    for (long long i = 0; i < static_cast<long long>(n); i++) {
        const double v = from + double(i) * step;
        if (integral)
            out.push_back(static_cast<int64_t>(std::llround(v)));
        else
            out.push_back(v);
    }
    return out;
}

toml::array axis_values(const toml::node &node, const std::string &file, const AxisInfo &a)
{
    const std::string key = std::string("axes.") + a.name;
    auto fail = [&](const std::string &m) -> void { throw SweepError(file + ": " + key + ": " + m); };
    toml::array out;
    if (const toml::table *t = node.as_table()) {
        if (a.type == AxisInfo::string || a.type == AxisInfo::edges)
            fail("a range {from, to, step} needs numbers; give a list of values");
        toml::table wrapper;
        wrapper.insert(a.name, *t);
        scene::Fields outer(wrapper, file, "axes", {a.name});
        auto r = outer.table(a.name, {"from", "to", "step"});
        out = expand_range(*r, a);
    } else if (const toml::array *arr = node.as_array()) {
        if (arr->empty())
            fail("empty list: give at least one value");
        for (size_t i = 0; i < arr->size(); i++) {
            const toml::node &v = *arr->get(i);
            const std::string at = "value " + std::to_string(i + 1) + " ";
            bool ok = false;
            switch (a.type) {
            case AxisInfo::integer:
                ok = v.is_integer();
                break;
            case AxisInfo::number:
                ok = v.is_integer() || v.is_floating_point();
                break;
            case AxisInfo::string:
                ok = v.is_string();
                break;
            case AxisInfo::edges:
                ok = v.is_string() || v.is_table();
                break;
            }
            if (!ok) {
                static const char *wanted[] = {"an integer", "a number", "a string",
                                               "an edge name or a table {left, right, bottom, top}"};
                fail(at + "must be " + std::string(wanted[a.type]) + ", got " + type_name(v));
            }
            if (a.type == AxisInfo::number && v.is_integer())
                out.push_back(double(*v.value<int64_t>()));
            else
                v.visit([&](const auto &x) { out.push_back(x); });
        }
    } else {
        fail(std::string("must be a list of values or a range {from, to, step}, got ") + type_name(node));
    }
    return out;
}

std::string value_text(const toml::node &v)
{
    std::ostringstream s;
    if (const toml::table *t = v.as_table()) {
        // Per-edge conditions, in a fixed order: left/right/bottom/top.
        std::string r;
        for (const char *k : {"left", "right", "bottom", "top"}) {
            const auto e = (*t)[k].value<std::string>();
            if (!r.empty())
                r += '/';
            r += e.value_or("?");
        }
        return r;
    }
    if (auto str = v.value_exact<std::string>())
        return *str;
    if (auto d = v.value_exact<double>()) {
        char b[40];
        std::snprintf(b, sizeof b, "%.10g", *d);
        return b;
    }
    if (auto i = v.value_exact<int64_t>())
        return std::to_string(*i);
    v.visit([&](const auto &x) { s << x; });
    return s.str();
}

std::string read_file(const std::string &path, const std::string &what)
{
    std::optional<std::string> bytes = io::read_file(path);
    if (!bytes)
        throw SweepError(what + ": cannot open \"" + path + "\"");
    return std::move(*bytes);
}

} // namespace

std::string known_axis_names()
{
    std::string r;
    for (const AxisInfo &a : axis_table)
        r += (r.empty() ? "" : ", ") + std::string(a.name);
    return r;
}

std::string fnv1a_hex(std::string_view bytes)
{
    uint64_t h = 14695981039346656037ull;
    for (unsigned char c : bytes) {
        h ^= c;
        h *= 1099511628211ull;
    }
    char b[17];
    std::snprintf(b, sizeof b, "%016llx", static_cast<unsigned long long>(h));
    return b;
}

std::size_t Sweep::case_count() const
{
    std::size_t n = 1;
    for (const Axis &a : axes)
        n *= a.values.size();
    return n;
}

Sweep parse_sweep(std::string_view text, const std::string &file, std::size_t max_cases)
{
    Sweep s;
    s.file = file;
    toml::table root;
    try {
        root = toml::parse(text, file);
    } catch (const toml::parse_error &e) {
        std::ostringstream msg;
        msg << file << ":" << e.source().begin.line << ":" << e.source().begin.column
            << ": TOML syntax error: " << e.description();
        throw SweepError(msg.str());
    }
    try {
        scene::Fields top(root, file, "", {"base", "name", "set", "axes", "constraints"});
        if (top.has("set")) {
            if (!root["set"].is_table())
                top.fail("set", "must be a table of scene sections ([set.plate], ...)");
            s.set = *root["set"].as_table();
        }
        const auto base = top.string("base");
        if (!base)
            top.fail("base", "missing (required): the base scene, relative to the sweep file");
        const std::filesystem::path dir = std::filesystem::path(file).parent_path();
        s.base_path = std::filesystem::path(*base).is_absolute() ? *base : (dir / *base).lexically_normal().string();
        s.name = top.string("name").value_or(std::filesystem::path(file).stem().string());
        if (top.has("axes")) {
            if (!root["axes"].is_table())
                top.fail("axes", "must be a table of axis = [values] or {from, to, step}");
            const toml::table &axes = *root["axes"].as_table();
            // Refuses unknown axes by name, listing the known ones.
            std::vector<const char *> names;
            for (const AxisInfo &a : axis_table)
                names.push_back(a.name);
            for (const auto &[k, v] : axes) {
                const AxisInfo *a = nullptr;
                for (const AxisInfo &x : axis_table)
                    if (k.str() == x.name)
                        a = &x;
                if (!a)
                    throw SweepError(file + ": axes." + std::string(k.str()) +
                                     ": unknown axis (known: " + known_axis_names() + ")");
                s.axes.push_back({a->kind, a->name, axis_values(v, file, *a)});
            }
            // toml++ tables are ordered by key; keep the file's order instead,
            // which is the order the user reads the cases in.
            std::stable_sort(s.axes.begin(), s.axes.end(), [&](const Axis &x, const Axis &y) {
                const toml::source_position p = axes.get(x.name)->source().begin, q = axes.get(y.name)->source().begin;
                return p.line != q.line ? p.line < q.line : p.column < q.column;
            });
        }
        if (auto c = top.table("constraints", {"min_contrast_db", "max_spot_m", "max_lead_time_s", "max_exciters"})) {
            if (auto v = c->number("min_contrast_db"))
                s.constraints.min_contrast_db = *v;
            if (auto v = c->positive("max_spot_m"))
                s.constraints.max_spot_m = *v;
            if (auto v = c->positive("max_lead_time_s"))
                s.constraints.max_lead_time_s = *v;
            if (auto v = c->integer("max_exciters")) {
                if (*v < 1)
                    c->fail("max_exciters", "must be >= 1");
                s.constraints.max_exciters = static_cast<unsigned>(*v);
            }
        }
    } catch (const scene::SceneError &e) {
        throw SweepError(e.what());
    }
    double n = 1;
    for (const Axis &a : s.axes)
        n *= double(a.values.size());
    if (n > double(max_cases))
        throw SweepError(file + ": axes: " + scene::format_number(n) + " cases (at most " + std::to_string(max_cases) +
                         ")");
    s.base_text = read_file(s.base_path, file + ": base");
    try {
        (void)toml::parse(s.base_text, s.base_path);
    } catch (const toml::parse_error &e) {
        throw SweepError(s.base_path + ":" + std::to_string(e.source().begin.line) +
                         ": TOML syntax error: " + std::string(e.description()));
    }
    return s;
}

Sweep load_sweep(const std::string &path) { return parse_sweep(read_file(path, "sweep"), path); }

namespace {

// [set] into the base: tables merge key by key, anything else replaces.
void merge(toml::table &into, const toml::table &from)
{
    for (const auto &[k, v] : from) {
        toml::table *sub = into[k].as_table();
        if (sub && v.is_table())
            merge(*sub, *v.as_table());
        else
            v.visit([&](const auto &x) { into.insert_or_assign(k, x); });
    }
}

} // namespace

std::vector<Case> enumerate_cases(const Sweep &s)
{
    toml::table base = toml::parse(s.base_text, s.base_path);
    merge(base, s.set);
    const std::size_t n = s.case_count();
    std::vector<Case> cases(n);
    for (std::size_t i = 0; i < n; i++) {
        toml::table t = base;
        Case &c = cases[i];
        c.index = i;
        // Mixed radix, last axis fastest.
        std::size_t rest = i;
        std::vector<std::size_t> pick(s.axes.size());
        for (std::size_t a = s.axes.size(); a-- > 0;) {
            pick[a] = rest % s.axes[a].values.size();
            rest /= s.axes[a].values.size();
        }
        for (std::size_t a = 0; a < s.axes.size(); a++) {
            const AxisInfo &ai = info(s.axes[a].kind);
            const toml::node &v = *s.axes[a].values.get(pick[a]);
            if (!t.contains(ai.section))
                t.insert(ai.section, toml::table{});
            toml::table *sec = t[ai.section].as_table();
            if (!sec)
                throw SweepError(s.base_path + ": " + ai.section + ": must be a table (the sweep sets " + ai.section +
                                 "." + ai.key + ")");
            // A swept edge condition or material replaces the base's, whatever its form.
            v.visit([&](const auto &x) { sec->insert_or_assign(ai.key, x); });
            c.values.push_back(value_text(v));
        }
        std::ostringstream text;
        text << t << "\n";
        c.scene_text = text.str();
        c.id = fnv1a_hex(c.scene_text);
    }
    return cases;
}

} // namespace calib::study
