// WAV files of the bench (docs/bench.md): the plan calibgen writes (PCM_16,
// what boards play) and the recordings a lab brings back, read whole through
// libsndfile.
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace calib::scene {

struct WavData {
    double rate_hz = 0;
    std::size_t frames = 0, channels = 0;
    // frames x channels, interleaved ([frame][channel]), normalised to full
    // scale: a PCM count over 2^(bits - 1) (libsndfile's reading), so in [-1, 1).
    std::vector<double> samples;
    double at(std::size_t frame, std::size_t channel) const { return samples[frame * channels + channel]; }
    // Frames [first, first + count) of one channel (zeros past the end).
    std::vector<double> channel(std::size_t c, std::size_t first, std::size_t count) const;
};

// Throws std::runtime_error "<path>: <why>" when the file cannot be read as sound.
WavData read_wav(const std::string &path);

// The bytes of a WAV file of 16-bit PCM samples (interleaved [frame][channel]),
// for io::write_file_atomic. Throws std::runtime_error if libsndfile refuses.
std::string wav_pcm16_bytes(const std::vector<int16_t> &interleaved, std::size_t channels, unsigned rate_hz);
// The same with 32-bit float samples (full scale 1; a simulated recording).
std::string wav_float_bytes(const std::vector<float> &interleaved, std::size_t channels, unsigned rate_hz);

} // namespace calib::scene
