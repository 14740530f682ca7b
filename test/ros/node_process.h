// calibration_node as a child process of a rostest's gtest node (restart and hostile-topic tests).
#ifndef INSITU_CALIBRATION_TEST_ROS_NODE_PROCESS_H
#define INSITU_CALIBRATION_TEST_ROS_NODE_PROCESS_H

#include <csignal>
#include <fstream>
#include <string>

#include <fcntl.h>
#include <spawn.h>
#include <unistd.h>
#include <sys/wait.h>

extern char** environ;

// The node as a child process; stopped with SIGINT (as roslaunch does) when the object goes.
class NodeProcess
{
public:
  // output_file: where the node's stdout and stderr go (empty: inherited).
  explicit NodeProcess(const std::string& node_name = "restart_node", const std::string& output_file = "")
  {
    std::string executable = std::string(INSITU_NODE_DIR) + "/calibration_node";
    std::string name = "__name:=" + node_name;
    char* argv[] = {executable.data(), name.data(), nullptr};
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    if (!output_file.empty())
    {
      posix_spawn_file_actions_addopen(&actions, 1, output_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      posix_spawn_file_actions_adddup2(&actions, 1, 2);
    }
    started_ = posix_spawn(&pid_, executable.c_str(), &actions, nullptr, argv, environ) == 0;
    posix_spawn_file_actions_destroy(&actions);
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
  // The exit status once the node has exited by itself within timeout_s; -1 if it still runs then.
  int waitForExit(double timeout_s)
  {
    for (double waited = 0.0; started_ && waited < timeout_s; waited += 0.05)
    {
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_)
      {
        started_ = false;
        exit_status_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
        return exit_status_;
      }
      usleep(50000);
    }
    return started_ ? -1 : exit_status_;
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
