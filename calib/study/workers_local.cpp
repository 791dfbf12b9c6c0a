#include "study/workers.h"

#include <algorithm>
#include <cstdlib>
#include <stdexcept>
#include <string>

namespace calib::study {

namespace {

class LocalWorkers final : public Workers {
  public:
    int rank() const override { return 0; }
    int size() const override { return 1; }
    int local_size() const override { return 1; }
    const char *kind() const override { return "local"; }
    void run(const std::vector<std::size_t> &todo, const RunCase &run, const StoreCase &store) override
    {
        for (std::size_t i : todo)
            store(i, run(i));
    }
};

[[maybe_unused]] int env_int(const char *name)
{
    const char *v = std::getenv(name);
    return v ? std::atoi(v) : 0;
}

} // namespace

bool launched_by_mpi()
{
    // Open MPI's launcher sets OMPI_COMM_WORLD_SIZE; PMIx and PMI launchers
    // (MPICH's hydra, Slurm's srun) set PMI_SIZE or PMIX_RANK.
    return std::getenv("OMPI_COMM_WORLD_SIZE") || std::getenv("PMI_SIZE") || std::getenv("PMIX_RANK");
}

std::unique_ptr<Workers> start_workers()
{
    if (!launched_by_mpi())
        return std::make_unique<LocalWorkers>();
#ifdef HAPTIC_MPI
    return start_mpi_workers();
#else
    const int n = std::max(env_int("OMPI_COMM_WORLD_SIZE"), env_int("PMI_SIZE"));
    if (n > 1)
        throw std::runtime_error("launched by mpirun with " + std::to_string(n) +
                                 " ranks, but this calibgen is built without MPI (configure with -DHAPTIC_MPI=ON)");
    return std::make_unique<LocalWorkers>();
#endif
}

} // namespace calib::study
