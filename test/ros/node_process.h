// calibration_node as a child process of a rostest's gtest node (restart and hostile-topic tests).
#ifndef INSITU_CALIBRATION_TEST_ROS_NODE_PROCESS_H
#define INSITU_CALIBRATION_TEST_ROS_NODE_PROCESS_H

#include <csignal>
#include <fstream>
#include <string>

#include <spawn.h>
#include <sys/wait.h>

extern char** environ;

// The node as a child process; stopped with SIGINT (as roslaunch does) when the object goes.
class NodeProcess
{
public:
  explicit NodeProcess(const std::string& node_name = "restart_node")
  {
    std::string executable = std::string(INSITU_NODE_DIR) + "/calibration_node";
    std::string name = "__name:=" + node_name;
    char* argv[] = {executable.data(), name.data(), nullptr};
    started_ = posix_spawn(&pid_, executable.c_str(), nullptr, nullptr, argv, environ) == 0;
  }
  ~NodeProcess() { stop(); }
  bool started() const { return started_; }
  // Resident memory of the node in kB (VmRSS), 0 when unknown.
  long residentKb() const
  {
    std::ifstream status("/proc/" + std::to_string(pid_) + "/status");
    std::string key;
    long value = 0;
    while (status >> key)
      if (key == "VmRSS:" && status >> value)
        return value;
    return 0;
  }
  // The exit status: 0 when the node shut down cleanly.
  int stop()
  {
    if (!started_)
      return exit_status_;
    kill(pid_, SIGINT);
    int status = 0;
    waitpid(pid_, &status, 0);
    started_ = false;
    exit_status_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    return exit_status_;
  }

private:
  pid_t pid_ = 0;
  bool started_ = false;
  int exit_status_ = -1;
};

#endif  // INSITU_CALIBRATION_TEST_ROS_NODE_PROCESS_H
