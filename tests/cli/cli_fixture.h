// cli_fixture.h — what the command-line tests share: a temporary directory per test, and running a
// tool with its exit code (or the signal that killed it), stdout, stderr and peak memory.
#pragma once

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <gtest/gtest.h>

namespace pcl_ecs_test
{

struct RunResult
{
  int code = -1;    ///< exit code; -1 when killed by a signal
  int signal = 0;   ///< the signal that ended it, 0 when it exited
  std::string out, err;
  long peak_rss_kib = 0;  ///< ru_maxrss of the process
};

inline std::string slurp(const std::string& p)
{
  std::ifstream in(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

/** \brief Run `command` through /bin/sh -c with stdout / stderr captured in files under `dir`. */
inline RunResult runCommand(const std::string& command, const std::string& dir)
{
  const std::string out = (std::filesystem::path(dir) / ".stdout").string();
  const std::string err = (std::filesystem::path(dir) / ".stderr").string();
  RunResult r;
  const pid_t pid = ::fork();
  if (pid == 0)
  {
    const std::string cmd = "exec " + command + " > " + out + " 2> " + err;
    ::execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  int status = 0;
  struct rusage usage = {};
  ::wait4(pid, &status, 0, &usage);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.signal = WIFSIGNALED(status) ? WTERMSIG(status) : 0;
  r.peak_rss_kib = usage.ru_maxrss;
  r.out = slurp(out);
  r.err = slurp(err);
  std::filesystem::remove(out);
  std::filesystem::remove(err);
  return r;
}

/** \brief A fresh temporary directory for each test, removed afterwards. */
class TempDirTest : public ::testing::Test
{
protected:
  void SetUp() override
  {
    char tmpl[] = "/tmp/pcl_ecs_cli_test_XXXXXX";
    ASSERT_NE(::mkdtemp(tmpl), nullptr);
    dir_ = tmpl;
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  std::string path(const std::string& name) const { return (std::filesystem::path(dir_) / name).string(); }
  RunResult runTool(const std::string& tool, const std::string& args) const
  {
    return runCommand(tool + " " + args, dir_);
  }

  std::string dir_;
};

}  // namespace pcl_ecs_test
