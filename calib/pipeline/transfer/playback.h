// A drive played through the transfer matrix: the displacement at chosen
// points of H is the sum over exciters of the force convolved with H,
//   w_p[n] = (1 / rate) sum_c sum_j F_c[j] H_c,p[n - j],
// computed by FFT (FFTW, single precision, plans made once and reused by every
// thread; FFTW's planner is not thread-safe, its execute functions are). Exact
// for the scheme at decimation 1 with the impulse force (the scheme is linear
// and time-invariant), band-limited otherwise (transfer.h).
//
// Memory: the spectra of the served points, channels x points x (nfft/2 + 1)
// complex floats, nfft >= drive + output samples.
#pragma once
#include "pipeline/data/input.h"
#include "pipeline/data/transfer_matrix.h"

#include <complex>
#include <cstddef>
#include <memory>
#include <vector>

namespace calib::pipeline {

class Playback {
  public:
    // Serves `points` (indices into H.points) for drives of up to
    // `drive_samples` and outputs of `output_samples`, both at H's rate.
    Playback(const TransferMatrix &H, std::vector<std::size_t> points, std::size_t drive_samples,
             std::size_t output_samples);
    ~Playback();
    Playback(const Playback &) = delete;
    Playback &operator=(const Playback &) = delete;

    std::size_t output_samples() const { return out_; }
    const std::vector<std::size_t> &points() const { return points_; }
    double bytes() const;

    // force[c][j] (N at H's rate, at most drive_samples long). Returns
    // w[i][n] (m) at points()[i] for n < output_samples, time n / rate.
    std::vector<std::vector<float>> field(const std::vector<std::vector<double>> &force) const;
    // Only the served points whose index into points() is in `which`.
    std::vector<std::vector<float>> field(const std::vector<std::vector<double>> &force,
                                          const std::vector<std::size_t> &which) const;

    // Each exciter's part of field(force, which) alone: w[c][i][n].
    std::vector<std::vector<std::vector<float>>> channel_fields(const std::vector<std::vector<double>> &force,
                                                                const std::vector<std::size_t> &which) const;

  private:
    // The drive's spectra, [channel][bin] (checks the channels and lengths).
    std::vector<std::complex<float>> drive_spectra(const std::vector<std::vector<double>> &force) const;
    struct Plans;
    const TransferMatrix &H_;
    std::vector<std::size_t> points_;
    std::size_t nfft_ = 0, bins_ = 0, out_ = 0, drive_ = 0;
    double scale_ = 0;
    std::vector<std::complex<float>> spectra_; // [point][channel][bin]
    std::unique_ptr<Plans> plans_;
};

// Force (N) at H's rate for one drive ([n][c] at full scale 1.0, rate_hz):
// band-limited resampling, the exciter's blocked force when the scene models it.
// What a stored drive applies to the plate, for every playback through H.
std::vector<std::vector<double>> drive_forces(const CalibrationInput &in, const TransferMatrix &H,
                                              const std::vector<float> &frames, unsigned channels, double rate_hz);

// FFT sizes FFTW does fast (2^a 3^b 5^c 7^d), at least n.
std::size_t fft_friendly_size(std::size_t n);

} // namespace calib::pipeline
