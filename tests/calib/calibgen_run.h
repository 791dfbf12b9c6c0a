// Running the calibgen program from a test (suites registered with
// haptic_gtest_runs_calibgen): its exit status and its stderr, with a hard
// time limit so that a hang fails the test instead of stalling the suite.
#pragma once
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace calibgen_run {

inline std::string read_text(const std::filesystem::path &p)
{
    std::ifstream f(p, std::ios::binary);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
}

struct Outcome {
    int exit_code = -1; // -1: killed or did not exit
    std::string err;
};

// The hang guard: 120 s a run, three times that in the sanitizer build, which
// runs calibgen 3-5x slower (a bench fit there took over 120 s on a loaded
// 2-core machine and was killed).
#ifdef HAPTIC_ASAN
inline constexpr const char *kill_after_s = "360";
#else
inline constexpr const char *kill_after_s = "120";
#endif

// `calibgen ARGS` (ARGS quoted by the caller), stderr kept in dir/stderr.txt.
inline Outcome run(const std::filesystem::path &dir, const std::string &args)
{
    const std::filesystem::path err = dir / "stderr.txt";
    const std::string cmd = std::string("timeout -s KILL ") + kill_after_s + " \"" HAPTIC_CALIBGEN "\" " + args +
                            " 2> \"" + err.string() + "\"";
    const int status = std::system(cmd.c_str());
    Outcome r;
    if (WIFEXITED(status))
        r.exit_code = WEXITSTATUS(status);
    r.err = read_text(err);
    return r;
}

// A suite whose every test runs calibgen in a fresh temporary directory of
// its own (`name`-PID under the system's), removed afterwards; run() keeps
// calibgen's stdout in `out`.
class Workdir : public ::testing::Test {
  protected:
    explicit Workdir(const std::string &name) : name_(name) {}
    void SetUp() override
    {
        dir = std::filesystem::temp_directory_path() / (name_ + "-" + std::to_string(::getpid()));
        std::filesystem::remove_all(dir);
        std::filesystem::create_directories(dir);
    }
    void TearDown() override { std::filesystem::remove_all(dir); }
    Outcome run(const std::string &args)
    {
        Outcome r = calibgen_run::run(dir, args + " > \"" + (dir / "stdout.txt").string() + "\"");
        out = read_text(dir / "stdout.txt");
        return r;
    }

    std::filesystem::path dir;
    std::string out;

  private:
    std::string name_;
};

} // namespace calibgen_run
