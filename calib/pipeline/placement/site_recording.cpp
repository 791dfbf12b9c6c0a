#include "pipeline/placement/site_recording.h"

#include "pipeline/signal/first_failure.h"
#include "pipeline/signal/resample.h"
#include "pipeline/transfer/transfer.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace calib::pipeline {

namespace {

// A site read off a copy of the field: the receiver's nodes and weights
// (PlateOperator::point_weights, the engine's own bilinear spreading), the
// weights rounded to the engine's precision as its receivers store them, so a
// frame gives exactly what a receiver would read at that step.
struct SiteTap {
    std::vector<std::size_t> node;
    std::vector<double> weight;
};

std::vector<SiteTap> taps_of(const engine::Simulation &sim, const std::vector<Point> &sites)
{
    const bool single = sim.precision() == engine::Precision::f32 && !sim.thick_plate();
    std::vector<SiteTap> taps(sites.size());
    for (std::size_t i = 0; i < sites.size(); i++)
        for (const auto &nw : sim.plate().point_weights(sites[i].x_m, sites[i].y_m)) {
            taps[i].node.push_back(nw.node);
            taps[i].weight.push_back(single ? double(static_cast<float>(nw.weight)) : nw.weight);
        }
    return taps;
}

} // namespace

SiteRecordingOptions site_recording_options(double k, double rate_hz)
{
    SiteRecordingOptions o;
    if (!(k > 0 && rate_hz > 0))
        throw std::invalid_argument("site recording: time step and rate must be positive");
    const auto m = static_cast<std::size_t>(std::floor(1.0 / (2.0 * rate_hz * k)));
    if (m < 2)
        return o; // too coarse to decimate: every step of the one-step impulse
    o.decimation = m;
    o.stop_hz = 0.5 / (double(m) * k);
    o.pass_hz = 0.5 * rate_hz;
    return o;
}

std::size_t site_recording_delay_steps(double k, const SiteRecordingOptions &o)
{
    if (o.stop_hz <= 0)
        return 0;
    std::size_t centre = 0;
    (void)band_limited_impulse(k, o.pass_hz, o.stop_hz, centre);
    return centre;
}

SiteRecording record_sites(engine::Simulation &sim, Point source, const std::vector<Point> &sites, std::size_t steps,
                           const SiteRecordingOptions &o)
{
    if (sim.steps_done() != 0)
        throw std::logic_error("record_sites: the simulation has run already");
    SiteRecording rec;
    const double k = sim.time_step_s();
    rec.decimation = std::max<std::size_t>(1, o.decimation);
    rec.rate_hz = 1.0 / (double(rec.decimation) * k);
    const std::size_t M = rec.decimation;
    const std::size_t src = sim.add_source(source.x_m, source.y_m);
    std::size_t centre = 0;
    sim.set_source_signal(src, impulse_force(k, o.pass_hz, o.stop_hz, centre));
    // Sample s is the state after step centre + s M: the response at (s M + 1) k.
    const std::size_t samples = (steps + M - 1) / M;
    const std::vector<SiteTap> taps = taps_of(sim, sites);
    rec.traces.assign(sites.size(), std::vector<double>(samples, 0.0));
    if (samples == 0)
        return rec;
    const std::size_t total = centre + (samples - 1) * M + 1;
    const std::size_t points = sim.plate().grid().node_count(); // the lattice of stride 1: every node
    sim.record_lattice(1, centre, M);
    std::size_t s = 0;
    std::vector<float> frames;
    for (std::size_t done = 0; done < total;) {
        const std::size_t run = std::min(total - done, site_recording_chunk_frames * M);
        sim.run(run);
        done += run;
        sim.take_lattice_frames(frames);
        for (std::size_t f = 0; f * points < frames.size(); f++, s++) {
            if (s >= samples)
                throw std::logic_error("record_sites: more frames than samples");
            const float *w = frames.data() + f * points;
            for (std::size_t i = 0; i < taps.size(); i++) {
                double v = 0;
                for (std::size_t t = 0; t < taps[i].node.size(); t++)
                    v += taps[i].weight[t] * double(w[taps[i].node[t]]);
                rec.traces[i][s] = v;
            }
        }
    }
    if (s != samples)
        throw std::logic_error("record_sites: " + std::to_string(s) + " frames recorded, " + std::to_string(samples) +
                               " expected");
    return rec;
}

std::vector<SiteRecording> record_sites_of(std::shared_ptr<const engine::PlateOperator> plate,
                                           const engine::SimulationOptions &options, const std::vector<Point> &sources,
                                           const std::vector<Point> &sites, std::size_t steps,
                                           const SiteRecordingOptions &o,
                                           const std::function<void(std::size_t, std::size_t)> &progress)
{
    std::vector<SiteRecording> out(sources.size());
    if (engine::lanes_apply(*plate, options)) {
        const double k = engine::kirchhoff_time_step(*plate, options);
        const std::size_t M = std::max<std::size_t>(1, o.decimation);
        std::vector<engine::LaneRecord> lanes =
            impulse_lanes(plate, options, sources, sites, 0, o.pass_hz, o.stop_hz, M, (steps + M - 1) / M, progress);
        for (std::size_t e = 0; e < sources.size(); e++) {
            out[e].decimation = M;
            out[e].rate_hz = 1.0 / (double(M) * k);
            out[e].traces = std::move(lanes[e].traces);
        }
        return out;
    }
    std::size_t done = 0;
    FirstFailure failure;
#pragma omp parallel for schedule(dynamic)
    for (std::size_t e = 0; e < sources.size(); e++) {
        try {
            engine::Simulation sim(plate, options);
            out[e] = record_sites(sim, sources[e], sites, steps, o);
        } catch (const std::exception &ex) {
            failure.keep(e, ex.what());
        }
#pragma omp critical(record_sites_of)
        {
            done++;
            if (progress)
                progress(done, sources.size());
        }
    }
    if (failure.failed())
        throw engine::SourceFailure(failure.item(), failure.what());
    return out;
}

std::vector<std::vector<double>> site_responses_at(const SiteRecording &rec, double k, std::size_t steps,
                                                   double rate_hz)
{
    // As resample() sizes a full-rate trace of `steps` samples.
    const auto len = static_cast<std::size_t>(std::llround(double(steps) * rate_hz / (1.0 / k)));
    std::vector<std::vector<double>> out = resample_all(rec.traces, rec.rate_hz, rate_hz);
    for (std::vector<double> &o : out)
        o.resize(len, 0.0);
    return out;
}

} // namespace calib::pipeline
