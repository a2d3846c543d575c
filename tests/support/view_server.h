#pragma once
// A running `omnipoint view` (the OMNIPOINT_CLI macro) for end-to-end tests: started with
// `--port 0`, its port read from the URL it prints, and killed when the object goes, also when
// a test fails (and by the kernel should the test process itself die).
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <regex>
#include <stdexcept>
#include <string>
#include <thread>

#include "support/cli_run.h"

namespace omnipoint::test {

class ViewServer {
 public:
  // Runs `omnipoint view ARGS --port 0`, its stdout and stderr in files in `scratch`; waits
  // until it prints its URL. A server that exits first or prints none -> std::runtime_error with
  // its stderr.
  ViewServer(const std::string& args, const std::filesystem::path& scratch)
      : out_(scratch / "view_stdout"), err_(scratch / "view_stderr") {
    std::filesystem::create_directories(scratch);
    const std::string command = std::string("exec ") + OMNIPOINT_CLI + " view " + args +
                                " --port 0 >" + out_.string() + " 2>" + err_.string();
    pid_ = ::fork();
    if (pid_ == 0) {
      ::prctl(PR_SET_PDEATHSIG, SIGKILL);
      ::execl("/bin/sh", "sh", "-c", command.c_str(), static_cast<char*>(nullptr));
      ::_exit(127);
    }
    const std::regex url(R"(at (http://[^ ]+:([0-9]+)/))");
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (std::chrono::steady_clock::now() < deadline) {
      std::smatch found;
      const std::string printed = slurp(out_);
      if (std::regex_search(printed, found, url)) {
        url_ = found[1];
        port_ = std::stoi(found[2]);
        return;
      }
      int status = 0;
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        throw std::runtime_error("omnipoint view exited: " + slurp(err_));
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    stop();
    throw std::runtime_error("omnipoint view printed no URL in 60 s: " + slurp(err_));
  }
  ViewServer(const ViewServer&) = delete;
  ViewServer& operator=(const ViewServer&) = delete;
  ~ViewServer() { stop(); }

  int port() const { return port_; }
  const std::string& url() const { return url_; }
  std::string err() const { return slurp(err_); }

 private:
  void stop() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, nullptr, 0);
    pid_ = -1;
  }

  std::filesystem::path out_, err_;
  pid_t pid_ = -1;
  int port_ = 0;
  std::string url_;
};

}  // namespace omnipoint::test
