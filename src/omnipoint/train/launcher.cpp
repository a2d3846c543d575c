#include "omnipoint/train/launcher.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>
#include <csignal>

#include <cerrno>
#include <chrono>
#include <climits>
#include <cstring>
#include <stdexcept>
#include <thread>

extern char** environ;

namespace omnipoint::train {
namespace {

constexpr auto kPollInterval = std::chrono::milliseconds(20);
constexpr auto kGracePeriod = std::chrono::seconds(5);

int exit_code(int status) {
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return 1;
}

// This process's environment without the variables the launcher sets, then `added`.
std::vector<std::string> child_environment(const std::vector<std::string>& added) {
  static const char* const kSet[] = {
      "RANK=", "LOCAL_RANK=", "WORLD_SIZE=", "LOCAL_WORLD_SIZE=", "MASTER_ADDR=", "MASTER_PORT="};
  std::vector<std::string> environment;
  for (char** entry = environ; *entry != nullptr; ++entry) {
    bool replaced = false;
    for (const char* prefix : kSet)
      replaced = replaced || std::strncmp(*entry, prefix, std::strlen(prefix)) == 0;
    if (!replaced) environment.emplace_back(*entry);
  }
  environment.insert(environment.end(), added.begin(), added.end());
  return environment;
}

std::vector<char*> c_strings(std::vector<std::string>& strings) {
  std::vector<char*> pointers;
  pointers.reserve(strings.size() + 1);
  for (std::string& s : strings) pointers.push_back(s.data());
  pointers.push_back(nullptr);
  return pointers;
}

// Stops the copies still running: SIGTERM, then SIGKILL for those alive after the grace period.
void stop_all(std::vector<pid_t>& running) {
  for (pid_t pid : running)
    if (pid > 0) kill(pid, SIGTERM);
  const auto deadline = std::chrono::steady_clock::now() + kGracePeriod;
  for (pid_t& pid : running) {
    while (pid > 0) {
      int status = 0;
      if (waitpid(pid, &status, WNOHANG) == pid) {
        pid = 0;
      } else if (std::chrono::steady_clock::now() >= deadline) {
        kill(pid, SIGKILL);
        waitpid(pid, &status, 0);
        pid = 0;
      } else {
        std::this_thread::sleep_for(kPollInterval);
      }
    }
  }
}

}  // namespace

std::string current_executable() {
  std::string path(PATH_MAX, '\0');
  const ssize_t length = readlink("/proc/self/exe", path.data(), path.size());
  if (length <= 0)
    throw std::runtime_error("launcher: cannot read /proc/self/exe: " +
                             std::string(std::strerror(errno)));
  path.resize(static_cast<size_t>(length));
  return path;
}

int free_port() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0)
    throw std::runtime_error("launcher: cannot open a socket: " +
                             std::string(std::strerror(errno)));
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  address.sin_port = 0;
  socklen_t length = sizeof(address);
  const bool ok = bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0 &&
                  getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length) == 0;
  const int error = errno;
  close(fd);
  if (!ok)
    throw std::runtime_error("launcher: cannot find a free port on 127.0.0.1: " +
                             std::string(std::strerror(error)));
  return ntohs(address.sin_port);
}

int launch_local(int nproc, const std::vector<std::string>& arguments,
                 const std::string& executable) {
  if (nproc < 1)
    throw std::invalid_argument("launch_local: --nproc " + std::to_string(nproc) +
                                ": expected at least 1");
  const std::string port = std::to_string(free_port());
  std::vector<pid_t> running;
  for (int rank = 0; rank < nproc; ++rank) {
    // Everything the child needs is built before fork: only execve runs in it.
    std::vector<std::string> argv_strings{executable};
    argv_strings.insert(argv_strings.end(), arguments.begin(), arguments.end());
    std::vector<std::string> env_strings = child_environment(
        {"RANK=" + std::to_string(rank), "LOCAL_RANK=" + std::to_string(rank),
         "WORLD_SIZE=" + std::to_string(nproc), "LOCAL_WORLD_SIZE=" + std::to_string(nproc),
         "MASTER_ADDR=127.0.0.1", "MASTER_PORT=" + port});
    std::vector<char*> argv = c_strings(argv_strings);
    std::vector<char*> envp = c_strings(env_strings);
    const pid_t launcher = getpid();
    const pid_t pid = fork();
    if (pid == 0) {
      // A rank ends with the launcher, however it ends (Ctrl-C, SIGTERM, SIGKILL): orphaned
      // ranks would go on training and writing into the run's folder beside a resumed run.
      prctl(PR_SET_PDEATHSIG, SIGTERM);
      if (getppid() != launcher) _exit(1);  // the launcher died before prctl
      execve(executable.c_str(), argv.data(), envp.data());
      _exit(127);
    }
    if (pid < 0) {
      const int error = errno;
      stop_all(running);
      throw std::runtime_error("launcher: cannot start rank " + std::to_string(rank) + " of " +
                               executable + ": " + std::strerror(error));
    }
    running.push_back(pid);
  }

  size_t remaining = running.size();
  while (remaining > 0) {
    for (pid_t& pid : running) {
      if (pid <= 0) continue;
      int status = 0;
      if (waitpid(pid, &status, WNOHANG) != pid) continue;
      pid = 0;
      --remaining;
      const int code = exit_code(status);
      if (code != 0) {
        stop_all(running);
        return code;
      }
    }
    if (remaining > 0) std::this_thread::sleep_for(kPollInterval);
  }
  return 0;
}

}  // namespace omnipoint::train
