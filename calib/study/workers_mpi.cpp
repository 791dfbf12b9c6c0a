// The MPI side of the study workers (workers.h): the only file that includes
// mpi.h. Protocol, all on MPI_COMM_WORLD:
//   worker -> rank 0, tag request: int64 index of the case just finished (-1
//       for none) followed by its record bytes;
//   rank 0 -> worker, tag reply: int64 index of the next case, -1 to stop.
// Rank 0 polls for requests (MPI_Iprobe from MPI_ANY_SOURCE, then a short
// sleep) instead of blocking in MPI_Recv, whose busy wait would take a core
// from the cases on a machine with few cores; it runs cases itself on a
// second thread that never calls MPI (MPI_THREAD_FUNNELED is enough).
// A rank that dies takes the job with it (plain MPI aborts on a lost
// process): what was stored stays, and a rerun resumes from it.
#include "study/workers.h"

#include <mpi.h>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <thread>

namespace calib::study {

namespace {

constexpr int tag_request = 1;
constexpr int tag_reply = 2;
constexpr auto poll_interval = std::chrono::milliseconds(5);

void check(int rc, const char *what)
{
    if (rc != MPI_SUCCESS)
        throw std::runtime_error(std::string("MPI: ") + what + " failed");
}

class MpiWorkers final : public Workers {
  public:
    MpiWorkers()
    {
        int provided = 0;
        check(MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided), "MPI_Init_thread");
        MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
        MPI_Comm_size(MPI_COMM_WORLD, &size_);
        MPI_Comm node;
        MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, rank_, MPI_INFO_NULL, &node);
        MPI_Comm_size(node, &local_size_);
        MPI_Comm_free(&node);
        if (provided < MPI_THREAD_FUNNELED) {
            MPI_Finalize();
            throw std::runtime_error("MPI: the library does not provide MPI_THREAD_FUNNELED");
        }
    }
    ~MpiWorkers() override
    {
        // Leaving by an exception on one rank would leave the others waiting
        // for it forever: end the whole job instead.
        if (std::uncaught_exceptions() > 0)
            MPI_Abort(MPI_COMM_WORLD, 1);
        else
            MPI_Finalize();
    }
    int rank() const override { return rank_; }
    int size() const override { return size_; }
    int local_size() const override { return local_size_; }
    const char *kind() const override { return "MPI"; }

    void run(const std::vector<std::size_t> &todo, const RunCase &run, const StoreCase &store) override
    {
        if (rank_ == 0)
            hand_out(todo, run, store);
        else
            work(run);
        wait_for_all();
    }

  private:
    void hand_out(const std::vector<std::size_t> &todo, const RunCase &run, const StoreCase &store)
    {
        std::mutex m;
        std::size_t next = 0;
        auto take = [&]() -> std::optional<std::size_t> {
            std::lock_guard lock(m);
            if (next == todo.size())
                return std::nullopt;
            return todo[next++];
        };
        std::mutex store_mutex;
        std::exception_ptr local_error;
        std::thread local([&] {
            try {
                while (auto i = take()) {
                    const std::string record = run(*i);
                    std::lock_guard lock(store_mutex);
                    store(*i, record);
                }
            } catch (...) {
                local_error = std::current_exception();
            }
        });
        try {
            dispatch(take, store, store_mutex);
        } catch (const std::exception &e) {
            // The local thread may be mid-case: only ending the job stops it.
            std::fprintf(stderr, "calibgen: %s\n", e.what());
            MPI_Abort(MPI_COMM_WORLD, 1);
        }
        local.join();
        if (local_error)
            std::rethrow_exception(local_error);
    }

    template <typename Take>
    void dispatch(Take &take, const StoreCase &store, std::mutex &store_mutex)
    {
        int active = size_ - 1;
        std::vector<char> buf;
        while (active > 0) {
            int flag = 0;
            MPI_Status st;
            MPI_Iprobe(MPI_ANY_SOURCE, tag_request, MPI_COMM_WORLD, &flag, &st);
            if (!flag) {
                std::this_thread::sleep_for(poll_interval);
                continue;
            }
            int n = 0;
            MPI_Get_count(&st, MPI_BYTE, &n);
            buf.resize(static_cast<std::size_t>(n));
            MPI_Recv(buf.data(), n, MPI_BYTE, st.MPI_SOURCE, tag_request, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
            int64_t done = -1;
            if (n >= int(sizeof done))
                std::memcpy(&done, buf.data(), sizeof done);
            if (done >= 0) {
                std::lock_guard lock(store_mutex);
                store(static_cast<std::size_t>(done),
                      std::string(buf.data() + sizeof done, static_cast<std::size_t>(n) - sizeof done));
            }
            const std::optional<std::size_t> i = take();
            const int64_t reply = i ? static_cast<int64_t>(*i) : -1;
            MPI_Send(&reply, 1, MPI_INT64_T, st.MPI_SOURCE, tag_reply, MPI_COMM_WORLD);
            if (!i)
                active--;
        }
    }

    void work(const RunCase &run)
    {
        int64_t done = -1;
        std::string record;
        for (;;) {
            std::vector<char> msg(sizeof done + record.size());
            std::memcpy(msg.data(), &done, sizeof done);
            std::memcpy(msg.data() + sizeof done, record.data(), record.size());
            MPI_Send(msg.data(), int(msg.size()), MPI_BYTE, 0, tag_request, MPI_COMM_WORLD);
            int64_t next = -1;
            MPI_Recv(&next, 1, MPI_INT64_T, 0, tag_reply, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
            if (next < 0)
                return;
            record = run(static_cast<std::size_t>(next));
            done = next;
        }
    }

    // A barrier that sleeps between tests: ranks that finish early do not
    // spin on a core the last cases still need.
    void wait_for_all()
    {
        MPI_Request req;
        MPI_Ibarrier(MPI_COMM_WORLD, &req);
        for (;;) {
            int flag = 0;
            MPI_Test(&req, &flag, MPI_STATUS_IGNORE);
            if (flag)
                return;
            std::this_thread::sleep_for(poll_interval * 4);
        }
    }

    int rank_ = 0, size_ = 1, local_size_ = 1;
};

} // namespace

std::unique_ptr<Workers> start_mpi_workers() { return std::make_unique<MpiWorkers>(); }

} // namespace calib::study
