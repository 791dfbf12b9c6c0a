// The whole of a file, as bytes: the one way calibgen reads a file it is given
// (a scene, a finished case of a study).
#pragma once
#include <optional>
#include <string>

namespace calib::io {

// Every byte of `path`; nothing when it cannot be opened (the caller says what
// the file was for).
std::optional<std::string> read_file(const std::string &path);

} // namespace calib::io
