// Helpers for tests that read and edit scene text: the fixture scenes of
// tests/calib/scenes/, one substitution, and the one-line error a scene
// raises when parsed and built.
#pragma once
#include "scene/scene.h"
#include "scene/toml_fields.h"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

namespace scene_text {

// The text of tests/calib/scenes/<name> (throws if it cannot be read).
inline std::string load(const std::string &name)
{
    const std::string path = std::string(HAPTIC_TEST_SCENES) + "/" + name;
    std::ifstream in(path, std::ios::binary);
    if (!in)
        throw std::runtime_error("cannot read test scene " + path);
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
}

// `text` with the first `from` replaced by `to` (a missing `from` fails the test).
inline std::string replace(std::string text, const std::string &from, const std::string &to)
{
    const auto at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos)
        text.replace(at, from.size(), to);
    return text;
}

// The SceneError message of parse_scene + build_plate ("" if none).
inline std::string error_of(const std::string &text, const std::string &file = "scene.toml")
{
    try {
        calib::scene::Scene s = calib::scene::parse_scene(text, file);
        calib::scene::build_plate(s);
    } catch (const calib::scene::SceneError &e) {
        return e.what();
    }
    return "";
}

} // namespace scene_text
