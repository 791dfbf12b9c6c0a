#include "scene/toml_fields.h"

#include <cmath>
#include <cstdio>

namespace calib::scene {

std::string format_number(double v)
{
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.10g", v);
    return buf;
}

Fields::Fields(const toml::table &table, std::string file, std::string path, std::initializer_list<const char *> known)
    : table_(table), file_(std::move(file)), path_(std::move(path))
{
    for (const char *k : known)
        known_.emplace_back(k);
    refuse_unknown();
}

std::string Fields::key_path(std::string_view key) const
{
    return path_.empty() ? std::string(key) : path_ + "." + std::string(key);
}

void Fields::fail(std::string_view key, const std::string &message) const
{
    throw SceneError(file_ + ": " + key_path(key) + ": " + message);
}

void Fields::refuse_unknown() const
{
    for (const auto &[k, v] : table_) {
        bool ok = false;
        for (const std::string &name : known_)
            ok = ok || name == k.str();
        if (!ok) {
            std::string list;
            for (const std::string &name : known_)
                list += (list.empty() ? "" : ", ") + name;
            fail(k.str(), "unknown key (known: " + list + ")");
        }
    }
}

std::optional<double> Fields::number(std::string_view key) const
{
    const toml::node *n = table_.get(key);
    if (!n)
        return std::nullopt;
    if (auto d = n->value_exact<double>())
        return *d;
    if (auto i = n->value_exact<int64_t>())
        return double(*i);
    fail(key, std::string("must be a number, got ") +
                  std::string(toml::impl::node_type_friendly_names[unsigned(n->type())]));
}

double Fields::required_number(std::string_view key) const
{
    if (auto v = number(key))
        return *v;
    fail(key, "missing (required)");
}

std::optional<double> Fields::positive(std::string_view key) const
{
    auto v = number(key);
    if (v && !(*v > 0 && std::isfinite(*v)))
        fail(key, "must be > 0, got " + format_number(*v));
    return v;
}

double Fields::required_positive(std::string_view key) const
{
    if (auto v = positive(key))
        return *v;
    fail(key, "missing (required)");
}

std::optional<std::string> Fields::string(std::string_view key) const
{
    const toml::node *n = table_.get(key);
    if (!n)
        return std::nullopt;
    if (auto s = n->value_exact<std::string>())
        return *s;
    fail(key, "must be a string");
}

std::optional<bool> Fields::boolean(std::string_view key) const
{
    const toml::node *n = table_.get(key);
    if (!n)
        return std::nullopt;
    if (auto b = n->value_exact<bool>())
        return *b;
    fail(key, "must be true or false");
}

std::optional<long long> Fields::integer(std::string_view key) const
{
    const toml::node *n = table_.get(key);
    if (!n)
        return std::nullopt;
    if (auto i = n->value_exact<int64_t>())
        return *i;
    fail(key, "must be an integer");
}

std::optional<std::vector<double>> Fields::numbers(std::string_view key, std::size_t count) const
{
    const toml::node *n = table_.get(key);
    if (!n)
        return std::nullopt;
    const toml::array *arr = n->as_array();
    if (!arr || arr->size() != count)
        fail(key, "must be an array of " + std::to_string(count) + " numbers");
    std::vector<double> out;
    for (const toml::node &e : *arr) {
        if (auto d = e.value_exact<double>())
            out.push_back(*d);
        else if (auto i = e.value_exact<int64_t>())
            out.push_back(double(*i));
        else
            fail(key, "must be an array of " + std::to_string(count) + " numbers");
    }
    return out;
}

std::optional<Fields> Fields::table(std::string_view key, std::initializer_list<const char *> known) const
{
    const toml::node *n = table_.get(key);
    if (!n)
        return std::nullopt;
    const toml::table *t = n->as_table();
    if (!t)
        fail(key, "must be a table");
    return Fields(*t, file_, key_path(key), known);
}

} // namespace calib::scene
