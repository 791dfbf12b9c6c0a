// Every file calibgen writes goes through here: a temporary file next to the
// target, then rename, so a reader never sees a half-written file and a
// failure leaves nothing behind.
#pragma once
#include <functional>
#include <iosfwd>
#include <string>
#include <string_view>

namespace calib::io {

// Writes `bytes` to `path` atomically. Throws std::runtime_error naming the path.
void write_file_atomic(const std::string &path, std::string_view bytes);

// Streams into a temporary file through `fill`, then renames it to `path`.
// If `fill` throws, the temporary file is removed and the exception passes on.
void write_stream_atomic(const std::string &path, const std::function<void(std::ostream &)> &fill);

} // namespace calib::io
