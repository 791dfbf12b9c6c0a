#include "io/atomic_file.h"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <unistd.h>

namespace calib::io {

void write_stream_atomic(const std::string &path, const std::function<void(std::ostream &)> &fill)
{
    const std::string tmp = path + ".tmp." + std::to_string(::getpid());
    try {
        {
            std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
            if (!out)
                throw std::runtime_error(path + ": cannot create: " + std::strerror(errno));
            fill(out);
            out.flush();
            if (!out)
                throw std::runtime_error(path + ": write failed: " + std::strerror(errno));
        }
        std::error_code ec;
        std::filesystem::rename(tmp, path, ec);
        if (ec)
            throw std::runtime_error(path + ": cannot move into place: " + ec.message());
    } catch (...) {
        std::error_code ignore;
        std::filesystem::remove(tmp, ignore);
        throw;
    }
}

void write_file_atomic(const std::string &path, std::string_view bytes)
{
    write_stream_atomic(
        path, [&](std::ostream &out) { out.write(bytes.data(), static_cast<std::streamsize>(bytes.size())); });
}

} // namespace calib::io
