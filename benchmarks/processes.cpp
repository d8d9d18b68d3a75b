// benchmarks/processes.cpp -- fresh processes and the competing load (processes.hpp).
#include "processes.hpp"

#include <cerrno>
#include <csignal>
#include <cstdint>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <thread>

#include <fcntl.h>
#include <spawn.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

extern char** environ;

namespace bench {

namespace {

std::string command_line(const std::string& program, const std::vector<std::string>& args) {
    std::string s = program;
    for (const std::string& a : args) s += " " + a;
    return s;
}

/// posix_spawn of program with args; stdout to `out_fd` when >= 0.
pid_t spawn(const std::string& program, const std::vector<std::string>& args, int out_fd, int close_fd) {
    std::vector<char*> argv;
    argv.push_back(const_cast<char*>(program.c_str()));
    for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    if (out_fd >= 0) posix_spawn_file_actions_adddup2(&fa, out_fd, STDOUT_FILENO);
    if (close_fd >= 0) posix_spawn_file_actions_addclose(&fa, close_fd);
    pid_t pid = -1;
    int rc = posix_spawn(&pid, program.c_str(), &fa, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&fa);
    if (rc != 0)
        throw std::runtime_error("cannot start '" + command_line(program, args) + "': " + std::strerror(rc));
    return pid;
}

int wait_for(pid_t pid) {
    int status = 0;
    while (waitpid(pid, &status, 0) < 0)
        if (errno != EINTR) return -1;
    return status;
}

}  // namespace

std::string self_executable() {
    std::string buf(4096, '\0');
    ssize_t n = readlink("/proc/self/exe", buf.data(), buf.size());
    if (n <= 0 || static_cast<std::size_t>(n) >= buf.size())
        throw std::runtime_error(std::string("cannot read /proc/self/exe: ") + std::strerror(errno));
    buf.resize(static_cast<std::size_t>(n));
    return buf;
}

std::string run_child(const std::string& program, const std::vector<std::string>& args) {
    int fds[2];
    if (pipe2(fds, O_CLOEXEC) != 0) throw std::runtime_error(std::string("pipe: ") + std::strerror(errno));
    pid_t pid = -1;
    try {
        pid = spawn(program, args, fds[1], fds[0]);
    } catch (...) {
        close(fds[0]);
        close(fds[1]);
        throw;
    }
    close(fds[1]);
    std::string out;
    char buf[4096];
    for (;;) {
        ssize_t n = read(fds[0], buf, sizeof buf);
        if (n > 0) {
            out.append(buf, static_cast<std::size_t>(n));
            continue;
        }
        if (n < 0 && errno == EINTR) continue;
        break;
    }
    close(fds[0]);
    int status = wait_for(pid);
    if (status < 0 || !WIFEXITED(status) || WEXITSTATUS(status) != 0) {
        std::string why = status < 0                ? "could not be waited for"
                          : WIFSIGNALED(status)     ? "was killed by signal " + std::to_string(WTERMSIG(status))
                          : WIFEXITED(status)       ? "exited with status " + std::to_string(WEXITSTATUS(status))
                                                    : "stopped";
        throw std::runtime_error("'" + command_line(program, args) + "' " + why);
    }
    return out;
}

CompetingLoad::CompetingLoad(std::size_t threads) {
    pid_ = spawn(self_executable(), {"--busy-child", std::to_string(getpid()), "--threads", std::to_string(threads)}, -1, -1);
}

CompetingLoad::~CompetingLoad() { stop(); }

double CompetingLoad::stop() {
    if (pid_ <= 0) return -1.0;
    const pid_t pid = pid_;
    pid_ = -1;
    // Reaped here when it stopped by itself (then never signalled: its pid may be reused).
    if (waitpid(pid, nullptr, WNOHANG) != 0) return -1.0;
    kill(pid, SIGKILL);
    int status = 0;
    struct rusage use {};
    while (wait4(pid, &status, 0, &use) < 0)
        if (errno != EINTR) return -1.0;
    auto seconds = [](const timeval& t) { return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec); };
    return seconds(use.ru_utime) + seconds(use.ru_stime);
}

int busy_child_main(long parent, std::size_t threads) {
    prctl(PR_SET_PDEATHSIG, SIGKILL);         // never outlive the measurement
    if (getppid() != parent) return 0;        // the parent is already gone
    auto busy = [] {
        constexpr std::size_t kWords = (8u << 20) / sizeof(std::uint64_t);
        std::unique_ptr<std::uint64_t[]> buf(new std::uint64_t[kWords]());
        std::uint64_t x = 0x9E3779B97F4A7C15ull;
        for (;;) {
            for (int k = 0; k < 1 << 20; ++k) x = (x ^ (x >> 29)) * 0xBF58476D1CE4E5B9ull + 1;  // the cores
            for (std::size_t i = 0; i < kWords; i += 8) buf[i] += x++;                          // caches, memory
            asm volatile("" : : "r"(buf.get()), "r"(x) : "memory");
        }
    };
    std::vector<std::thread> pool;
    for (std::size_t t = 1; t < threads; ++t) pool.emplace_back(busy);
    busy();
    return 0;
}

}  // namespace bench
