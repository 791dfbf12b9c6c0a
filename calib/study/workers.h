// Who runs the cases of a study: this process alone, or every rank of an
// MPI job (`mpirun -np N calibgen study design ...`). Only workers_mpi.cpp
// knows MPI; the rest of calibgen builds and runs without it.
//
// Under MPI, rank 0 hands out case indices one at a time to whichever rank
// asks (dynamic assignment: a long case does not hold back the others) and
// also runs cases itself on a second thread. Every finished case travels back
// to rank 0 with the next request, and rank 0 alone writes results, so the
// ranks need not share a file system.
#pragma once
#include <cstddef>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace calib::study {

// Computes case `index` and returns its result record.
using RunCase = std::function<std::string(std::size_t index)>;
// Rank 0 only: keeps a finished case's record (called from more than one
// thread, never at once: the workers serialize the calls).
using StoreCase = std::function<void(std::size_t index, const std::string &record)>;

class Workers {
  public:
    virtual ~Workers() = default;
    virtual int rank() const = 0;
    virtual int size() const = 0;
    // Ranks on this machine (cores are shared among them).
    virtual int local_size() const = 0;
    virtual const char *kind() const = 0; // "local" or "MPI"
    // Every rank calls this; `todo` is read on rank 0 only. Returns on every
    // rank once every case in `todo` is stored.
    virtual void run(const std::vector<std::size_t> &todo, const RunCase &run, const StoreCase &store) = 0;
};

// True when the process was started by an MPI launcher (mpirun, mpiexec).
bool launched_by_mpi();

// MPI workers when launched by mpirun and built with MPI; local otherwise.
// Throws std::runtime_error when launched by mpirun with more than one rank
// but built without MPI (each rank would run the whole sweep).
std::unique_ptr<Workers> start_workers();

// The MPI workers (workers_mpi.cpp, built with HAPTIC_MPI only).
std::unique_ptr<Workers> start_mpi_workers();

} // namespace calib::study
