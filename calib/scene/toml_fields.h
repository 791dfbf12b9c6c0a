// Reading one TOML table of a scene with errors that name the file and the
// key, and refusal of keys the section does not know. Every section parser
// (scene.cpp, calibration_sections.cpp, effects_section.cpp) uses this.
#pragma once

#include <toml++/toml.h>

#include <initializer_list>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace calib::scene {

// One line: "<file>: <key path>: <what is wrong>".
class SceneError : public std::runtime_error {
  public:
    using std::runtime_error::runtime_error;
};

class Fields {
  public:
    // `path` is the dotted name of this table ("plate", "plate.loss").
    Fields(const toml::table &table, std::string file, std::string path, std::initializer_list<const char *> known);

    const std::string &file() const { return file_; }
    std::string key_path(std::string_view key) const;
    bool has(std::string_view key) const { return table_.contains(key); }
    const toml::node *node(std::string_view key) const { return table_.get(key); }

    std::optional<double> number(std::string_view key) const; // int or float
    double required_number(std::string_view key) const;
    std::optional<double> positive(std::string_view key) const; // > 0 and finite
    double required_positive(std::string_view key) const;
    std::optional<std::string> string(std::string_view key) const;
    std::optional<long long> integer(std::string_view key) const;
    std::optional<bool> boolean(std::string_view key) const; // true or false, nothing else
    // An array of exactly `n` numbers.
    std::optional<std::vector<double>> numbers(std::string_view key, std::size_t n) const;
    std::optional<Fields> table(std::string_view key, std::initializer_list<const char *> known) const;

    [[noreturn]] void fail(std::string_view key, const std::string &message) const;

  private:
    void refuse_unknown() const;

    const toml::table &table_;
    std::string file_;
    std::string path_;
    std::vector<std::string> known_;
};

// "-1", "0.002", "1e+09": the value as the user wrote it, for messages.
std::string format_number(double v);

} // namespace calib::scene
