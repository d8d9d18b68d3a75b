// benchmarks/processes.hpp -- sylva-bench's helper processes (issue 15, item 2): the fresh
// processes that time a cold first build, and the competing load of --load. Both are this same
// executable, started again with a hidden option (options.cpp), so that what runs in them is
// exactly the code the parent measures.
#ifndef SYLVA_BENCH_PROCESSES_HPP
#define SYLVA_BENCH_PROCESSES_HPP

#include <string>
#include <sys/types.h>
#include <vector>

namespace bench {

/// The running executable (/proc/self/exe); throws when it cannot be read.
std::string self_executable();

/// Runs `program` with `args` (argv[1..]) and returns what it wrote on stdout; its stderr is
/// ours. Throws std::runtime_error naming the command when it cannot start, is killed or exits
/// non-zero.
std::string run_child(const std::string& program, const std::vector<std::string>& args);

/// A busy process on every core while it lives: `threads` threads of this executable's
/// `--busy-child` (busy_child_main), each alternating integer work with passes over its own
/// 8 MiB buffer (the mix of a compiler: cores, caches and memory bandwidth all taken). Killed
/// and reaped on destruction; it also dies with its parent (PR_SET_PDEATHSIG).
class CompetingLoad {
public:
    explicit CompetingLoad(std::size_t threads);
    ~CompetingLoad();
    /// Kills and reaps the busy process; returns the CPU seconds it used (user + system), or -1
    /// when it had stopped already or cannot be reaped. Later calls return -1.
    double stop();
    CompetingLoad(const CompetingLoad&) = delete;
    CompetingLoad& operator=(const CompetingLoad&) = delete;

private:
    pid_t pid_ = -1;
};

/// The body of `--busy-child PID`: runs `threads` busy threads until killed, or returns at once
/// when process `parent` (the one that started it) is gone already.
int busy_child_main(long parent, std::size_t threads);

}  // namespace bench

#endif  // SYLVA_BENCH_PROCESSES_HPP
