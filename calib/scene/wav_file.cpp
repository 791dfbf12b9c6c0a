#include "scene/wav_file.h"

#include <sndfile.h>

#include <algorithm>
#include <cstring>
#include <memory>
#include <stdexcept>

namespace calib::scene {

std::vector<double> WavData::channel(std::size_t c, std::size_t first, std::size_t count) const
{
    std::vector<double> out(count, 0.0);
    for (std::size_t i = 0; i < count && first + i < frames; i++)
        out[i] = at(first + i, c);
    return out;
}

WavData read_wav(const std::string &path)
{
    SF_INFO info{};
    SNDFILE *f = sf_open(path.c_str(), SFM_READ, &info);
    if (!f)
        throw std::runtime_error(path + ": " + sf_strerror(nullptr));
    std::unique_ptr<SNDFILE, int (*)(SNDFILE *)> guard(f, sf_close);
    if (info.channels < 1 || info.frames < 0 || info.samplerate < 1)
        throw std::runtime_error(path + ": no sound in it (" + std::to_string(info.channels) + " channels, " +
                                 std::to_string(info.samplerate) + " Hz)");
    WavData w;
    w.rate_hz = info.samplerate;
    w.channels = static_cast<std::size_t>(info.channels);
    w.frames = static_cast<std::size_t>(info.frames);
    w.samples.resize(w.frames * w.channels);
    // Floating-point files as they are (no clipping at full scale: a clipped
    // recording must stay visible as such).
    sf_command(f, SFC_SET_CLIPPING, nullptr, SF_FALSE);
    const sf_count_t got = sf_readf_double(f, w.samples.data(), info.frames);
    if (got != info.frames)
        throw std::runtime_error(path + ": short read (" + std::to_string(got) + " of " + std::to_string(info.frames) +
                                 " frames)");
    return w;
}

namespace {

// libsndfile's virtual I/O into a string.
struct Memory {
    std::string bytes;
    sf_count_t pos = 0;
};

sf_count_t mem_length(void *user) { return static_cast<sf_count_t>(static_cast<Memory *>(user)->bytes.size()); }

sf_count_t mem_seek(sf_count_t offset, int whence, void *user)
{
    auto *m = static_cast<Memory *>(user);
    const sf_count_t base = whence == SEEK_SET ? 0 : whence == SEEK_CUR ? m->pos : sf_count_t(m->bytes.size());
    m->pos = std::max<sf_count_t>(0, base + offset);
    return m->pos;
}

sf_count_t mem_read(void *ptr, sf_count_t count, void *user)
{
    auto *m = static_cast<Memory *>(user);
    const sf_count_t size = sf_count_t(m->bytes.size());
    const sf_count_t n = std::max<sf_count_t>(0, std::min(count, size - m->pos));
    if (n > 0)
        std::memcpy(ptr, m->bytes.data() + m->pos, static_cast<std::size_t>(n));
    m->pos += n;
    return n;
}

sf_count_t mem_write(const void *ptr, sf_count_t count, void *user)
{
    auto *m = static_cast<Memory *>(user);
    const auto end = static_cast<std::size_t>(m->pos + count);
    if (m->bytes.size() < end)
        m->bytes.resize(end);
    std::memcpy(m->bytes.data() + m->pos, ptr, static_cast<std::size_t>(count));
    m->pos += count;
    return count;
}

sf_count_t mem_tell(void *user) { return static_cast<Memory *>(user)->pos; }

} // namespace

namespace {

// Interleaved samples of one type into WAV bytes of a libsndfile subformat.
template <typename T, typename Write>
std::string wav_bytes(const std::vector<T> &interleaved, std::size_t channels, unsigned rate_hz, int subformat,
                      Write write)
{
    if (channels == 0 || interleaved.size() % channels != 0)
        throw std::runtime_error("WAV: " + std::to_string(interleaved.size()) + " samples do not make frames of " +
                                 std::to_string(channels) + " channels");
    SF_VIRTUAL_IO io{mem_length, mem_seek, mem_read, mem_write, mem_tell};
    Memory mem;
    SF_INFO info{};
    info.samplerate = static_cast<int>(rate_hz);
    info.channels = static_cast<int>(channels);
    info.format = SF_FORMAT_WAV | subformat;
    SNDFILE *f = sf_open_virtual(&io, SFM_WRITE, &info, &mem);
    if (!f)
        throw std::runtime_error(std::string("WAV: ") + sf_strerror(nullptr));
    const auto frames = static_cast<sf_count_t>(interleaved.size() / channels);
    const sf_count_t put = write(f, interleaved.data(), frames);
    const std::string err = sf_strerror(f);
    sf_close(f);
    if (put != frames)
        throw std::runtime_error("WAV: " + err);
    return std::move(mem.bytes);
}

} // namespace

std::string wav_pcm16_bytes(const std::vector<int16_t> &interleaved, std::size_t channels, unsigned rate_hz)
{
    return wav_bytes(interleaved, channels, rate_hz, SF_FORMAT_PCM_16, sf_writef_short);
}

std::string wav_float_bytes(const std::vector<float> &interleaved, std::size_t channels, unsigned rate_hz)
{
    return wav_bytes(interleaved, channels, rate_hz, SF_FORMAT_FLOAT, sf_writef_float);
}

} // namespace calib::scene
