// Running the calibgen program from a test (suites registered with
// haptic_gtest_runs_calibgen): its exit status and its stderr, with a hard
// time limit so that a hang fails the test instead of stalling the suite.
#pragma once
#include <sys/wait.h>

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

// `calibgen ARGS` (ARGS quoted by the caller), stderr kept in dir/stderr.txt.
inline Outcome run(const std::filesystem::path &dir, const std::string &args)
{
    const std::filesystem::path err = dir / "stderr.txt";
    const std::string cmd = "timeout -s KILL 120 \"" HAPTIC_CALIBGEN "\" " + args + " 2> \"" + err.string() + "\"";
    const int status = std::system(cmd.c_str());
    Outcome r;
    if (WIFEXITED(status))
        r.exit_code = WEXITSTATUS(status);
    r.err = read_text(err);
    return r;
}

} // namespace calibgen_run
