// vision_host as a child process, as a robot's service manager runs it, with its output captured.
#pragma once

#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

class HostProcess {
 public:
  using Clock = std::chrono::steady_clock;

  // Runs `executable args...`; with a shell_prefix ("ulimit -f 1024 &&"), through bash with it first.
  explicit HostProcess(const std::vector<std::string>& args, const std::string& shell_prefix = "",
                       const std::string& executable = VISION_HOST_EXE) {
    int fds[2];
    if (pipe(fds) != 0) throw std::runtime_error("pipe failed");
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, fds[1], STDOUT_FILENO);
    posix_spawn_file_actions_adddup2(&actions, fds[1], STDERR_FILENO);
    posix_spawn_file_actions_addclose(&actions, fds[0]);
    std::vector<std::string> all{executable};
    all.insert(all.end(), args.begin(), args.end());
    if (!shell_prefix.empty()) {
      std::string command = shell_prefix + " exec";
      for (const std::string& arg : all) command += " '" + arg + "'";
      all = {"/bin/bash", "-c", command};
    }
    std::vector<char*> argv;
    for (auto& arg : all) argv.push_back(arg.data());
    argv.push_back(nullptr);
    if (posix_spawn(&pid_, argv[0], &actions, nullptr, argv.data(), environ) != 0) {
      throw std::runtime_error("cannot start " + all.front());
    }
    posix_spawn_file_actions_destroy(&actions);
    close(fds[1]);
    out_fd_ = fds[0];
  }
  ~HostProcess() {
    if (pid_ > 0) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
    if (out_fd_ >= 0) close(out_fd_);
  }
  HostProcess(const HostProcess&) = delete;
  HostProcess& operator=(const HostProcess&) = delete;

  void signal(int signal_number) { kill(pid_, signal_number); }
  // The reader of the host's output goes away.
  void closeOutput() {
    close(out_fd_);
    out_fd_ = -1;
  }

  // Reads the output until it holds text (true) or the deadline passes or the output ends (false).
  bool waitForOutput(const std::string& text, std::chrono::milliseconds timeout = std::chrono::seconds(60)) {
    const auto deadline = Clock::now() + timeout;
    while (output_.find(text) == std::string::npos) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
      if (left <= 0 || !readSome(static_cast<int>(left))) return false;
    }
    return true;
  }

  // Reads what it printed so far without waiting (so that a chatty host never blocks on a full pipe).
  void drainOutput() {
    while (readSome(0)) {
    }
  }

  // Waits for exit up to timeout, reading its output meanwhile (a host that prints more than the pipe
  // holds would otherwise block); returns the exit status or -1 on timeout.
  int waitExit(std::chrono::milliseconds timeout) {
    const auto deadline = Clock::now() + timeout;
    while (Clock::now() < deadline) {
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      }
      drainOutput();
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return -1;
  }
  // Everything it printed (call after it exited: reads to the end).
  std::string readAll() {
    while (readSome(-1)) {
    }
    return output_;
  }

 private:
  // Reads what is there within timeout_ms (-1: until something comes or the output ends); false at its end.
  bool readSome(int timeout_ms) {
    if (out_fd_ < 0) return false;
    pollfd fd{out_fd_, POLLIN, 0};
    if (poll(&fd, 1, timeout_ms) <= 0) return timeout_ms > 0;  // nothing yet: true while there is time to wait
    char buffer[4096];
    const ssize_t n = read(out_fd_, buffer, sizeof buffer);
    if (n <= 0) return false;
    output_.append(buffer, static_cast<std::size_t>(n));
    return true;
  }

  pid_t pid_ = -1;
  int out_fd_ = -1;
  std::string output_;
};
