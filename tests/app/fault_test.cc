// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Faults during a ddoc-hopper run (issue 20, docs/reliability.md): SIGINT, SIGTERM, a fall, a
// non-finite state, a file size limit (a full disk for one file) and an output directory that
// disappears. Each must end with its message and exit code, every completed hop in hops.csv
// and, where the directory still takes writes, summary.json saying how the run ended.
#include <gtest/gtest.h>
#include <fcntl.h>
#include <poll.h>
#include <pty.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace {

namespace fs = std::filesystem;

std::string ReadFile(const fs::path& p) {
  std::ifstream f(p);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// Data rows of a CSV file (lines after the header); -1 when it does not exist.
int DataRows(const fs::path& p) {
  if (!fs::exists(p)) return -1;
  std::ifstream f(p);
  int lines = 0;
  for (std::string line; std::getline(f, line);) ++lines;
  return lines - 1;
}

// The value of a JSON field written by nlohmann's dump(2) ("key": value); "" when absent.
std::string Field(const std::string& json, const std::string& key) {
  const std::regex re("\"" + key + "\": (\"(?:[^\"\\\\]|\\\\.)*\"|[^,\\n]*)");
  std::smatch m;
  return std::regex_search(json, m, re) ? m[1].str() : "";
}

// Hop numbers in the first column of hops.csv are 0, 1, ..., rows - 1.
void ExpectConsecutiveHops(const fs::path& hops_csv) {
  std::ifstream f(hops_csv);
  std::string line;
  std::getline(f, line);
  for (int hop = 0; std::getline(f, line); ++hop) {
    EXPECT_EQ(line.substr(0, line.find(',')), std::to_string(hop)) << hops_csv;
  }
}

class FaultTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) /
           ("ddoc_fault_" +
            std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + "_" +
            std::to_string(::getpid()));  // two suites may run at once
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Starts ddoc-hopper in dir_ with `args` (output to dir_/console.txt), with a file size limit
  // in bytes when fsize > 0.
  void Start(const std::vector<std::string>& args, long fsize = 0) {
    std::vector<std::string> argv = {DDOC_HOPPER_BIN};
    argv.insert(argv.end(), args.begin(), args.end());
    const std::string console = (dir_ / "console.txt").string();
    pid_ = fork();
    ASSERT_GE(pid_, 0);
    if (pid_ == 0) {
      std::FILE* out = std::freopen(console.c_str(), "w", stdout);
      if (out == nullptr || dup2(fileno(stdout), STDERR_FILENO) < 0) _exit(126);
      if (chdir(dir_.c_str()) != 0) _exit(126);
      if (fsize > 0) {
        const rlimit limit{static_cast<rlim_t>(fsize), static_cast<rlim_t>(fsize)};
        if (setrlimit(RLIMIT_FSIZE, &limit) != 0) _exit(126);
      }
      std::vector<char*> cargv;
      for (std::string& a : argv) cargv.push_back(a.data());
      cargv.push_back(nullptr);
      execv(cargv[0], cargv.data());
      _exit(127);
    }
  }

  // Waits until `hops_csv` has at least `rows` data rows (or the run ended); false on timeout.
  bool WaitForHops(const fs::path& hops_csv, int rows) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(240);
    while (std::chrono::steady_clock::now() < deadline) {
      if (DataRows(hops_csv) >= rows) return true;
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        status_ = status;
        return false;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return false;
  }

  // The exit code of the run (-signal when a signal killed it).
  int Wait() {
    if (!status_) {
      int status = 0;
      EXPECT_EQ(waitpid(pid_, &status, 0), pid_);
      status_ = status;
    }
    return WIFEXITED(*status_) ? WEXITSTATUS(*status_) : -WTERMSIG(*status_);
  }

  std::string Console() const { return ReadFile(dir_ / "console.txt"); }

  // Starts ddoc-hopper in dir_ with `args` on a pseudo-terminal (stdout and stderr are a tty,
  // read back with ReadTerminal), with the environment variable `env_name` set to `env_value`.
  void StartOnTerminal(const std::vector<std::string>& args, const char* env_name,
                       const char* env_value) {
    std::vector<std::string> argv = {DDOC_HOPPER_BIN};
    argv.insert(argv.end(), args.begin(), args.end());
    pid_ = forkpty(&terminal_, nullptr, nullptr, nullptr);
    ASSERT_GE(pid_, 0);
    if (pid_ == 0) {
      if (chdir(dir_.c_str()) != 0) _exit(126);
      setenv(env_name, env_value, 1);
      std::vector<char*> cargv;
      for (std::string& a : argv) cargv.push_back(a.data());
      cargv.push_back(nullptr);
      execv(cargv[0], cargv.data());
      _exit(127);
    }
    fcntl(terminal_, F_SETFL, O_NONBLOCK);
  }

  // Appends what the terminal shows within `seconds` to terminal_text_ (the run keeps writing).
  void ReadTerminal(double seconds) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    char buf[4096];
    while (std::chrono::steady_clock::now() < end) {
      pollfd p{terminal_, POLLIN, 0};
      if (poll(&p, 1, 20) <= 0) continue;
      const ssize_t n = read(terminal_, buf, sizeof(buf));
      if (n <= 0) {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        continue;
      }
      terminal_text_.append(buf, static_cast<size_t>(n));
    }
  }

  // Reads the terminal until the run exits (at most `limit` s); its exit status (as Wait) and
  // the seconds it took, or nullopt when it did not exit.
  std::optional<int> WaitOnTerminal(double limit, double* seconds) {
    const auto start = std::chrono::steady_clock::now();
    while (std::chrono::steady_clock::now() - start < std::chrono::duration<double>(limit)) {
      ReadTerminal(0.02);
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        *seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        status_ = status;
        ReadTerminal(0.1);
        return WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
      }
    }
    return std::nullopt;
  }

  // Every hop that summary.json counts is a row of hops.csv, and no more.
  void ExpectSummaryMatchesHops(const fs::path& out, const char* end) {
    const std::string summary = ReadFile(out / "summary.json");
    EXPECT_EQ(Field(summary, "end"), std::string("\"") + end + "\"") << summary;
    EXPECT_EQ(Field(summary, "hops"), std::to_string(DataRows(out / "hops.csv"))) << summary;
    ExpectConsecutiveHops(out / "hops.csv");
  }

  static std::string Scenario(const char* name) {
    return std::string(DDOC_MODELS_DIR) + "/scenarios/" + name;
  }

  fs::path dir_;
  pid_t pid_ = -1;
  std::optional<int> status_;
  int terminal_ = -1;
  std::string terminal_text_;
};

TEST_F(FaultTest, SigintEndsWithExitFourAndKeepsEveryHop) {
  const fs::path out = dir_ / "run";
  Start({Scenario("default.xml"), "--hops", "1000", "-q", "--out", out.string()});
  ASSERT_TRUE(WaitForHops(out / "hops.csv", 3)) << Console();
  ASSERT_EQ(kill(pid_, SIGINT), 0);
  EXPECT_EQ(Wait(), 4) << Console();
  EXPECT_NE(Console().find("interrupted by SIGINT"), std::string::npos) << Console();
  EXPECT_GE(DataRows(out / "hops.csv"), 3);
  ExpectSummaryMatchesHops(out, "interrupted");
  EXPECT_NE(Field(ReadFile(out / "summary.json"), "end_message").find("SIGINT"),
            std::string::npos);
}

// The start (the nominal gait and the u^0 solve on the model, about 0.5 s without a stored law
// on an idle machine) shows its progress on a terminal, and Ctrl-C there ends the run within
// 0.5 s with summary.json (it was silent, took about 6 s to react, and summary.json's wall time
// left the start out). The signal goes as soon as the progress line is on the terminal.
TEST_F(FaultTest, CtrlCDuringTheStartEndsAtOnceWithTheSummary) {
  const fs::path out = dir_ / "run";
  StartOnTerminal({Scenario("default.xml"), "--hops", "1000", "--out", out.string()},
                  "DDOC_LAW_CACHE", "");  // set and empty: no law cache, u^0 is solved
  const auto start = std::chrono::steady_clock::now();
  while (terminal_text_.find("u^0") == std::string::npos &&
         std::chrono::steady_clock::now() - start < std::chrono::seconds(10)) {
    ReadTerminal(0.005);
  }
  const double start_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_NE(terminal_text_.find("u^0"), std::string::npos) << terminal_text_;
  EXPECT_EQ(terminal_text_.find("hop "), std::string::npos) << "the start was over";
  ASSERT_EQ(kill(pid_, SIGINT), 0);
  double seconds = 0;
  const std::optional<int> code = WaitOnTerminal(30, &seconds);
  ASSERT_TRUE(code.has_value()) << terminal_text_;
  EXPECT_EQ(*code, 4) << terminal_text_;
  EXPECT_LT(seconds, 1.5) << "target 0.5 s (a loaded machine gets slack)";
  std::printf("ddoc-hopper ended %.3f s after SIGINT during the start\n", seconds);
  EXPECT_NE(terminal_text_.find("interrupted by SIGINT during the start"), std::string::npos)
      << terminal_text_;
  ExpectSummaryMatchesHops(out, "interrupted");
  EXPECT_EQ(Field(ReadFile(out / "summary.json"), "hops"), "0");
  // The wall time counts the start up to the signal.
  EXPECT_GE(std::stod(Field(ReadFile(out / "summary.json"), "wall_time_s")), 0.5 * start_seconds);
}

// A second SIGINT right after the first (an impatient Ctrl-C) still ends the run with its logs
// and summary.json (it killed the run); summary.json's wall time covers the whole run, start
// included.
TEST_F(FaultTest, ASecondSigintStillWritesTheSummary) {
  const fs::path out = dir_ / "run";
  const auto start = std::chrono::steady_clock::now();
  Start({Scenario("default.xml"), "--hops", "1000", "-q", "--out", out.string()});
  ASSERT_TRUE(WaitForHops(out / "hops.csv", 2)) << Console();
  ASSERT_EQ(kill(pid_, SIGINT), 0);
  ASSERT_EQ(kill(pid_, SIGINT), 0);
  EXPECT_EQ(Wait(), 4) << Console();
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_GE(DataRows(out / "hops.csv"), 2);
  ExpectSummaryMatchesHops(out, "interrupted");
  const double wall = std::stod(Field(ReadFile(out / "summary.json"), "wall_time_s"));
  EXPECT_GT(wall, 0.8 * elapsed - 0.2) << "the run took " << elapsed << " s";
  EXPECT_LE(wall, elapsed);
}

TEST_F(FaultTest, SigtermEndsWithExitFourAndKeepsEveryHop) {
  const fs::path out = dir_ / "run";
  Start({Scenario("default.xml"), "--hops", "1000", "-q", "--out", out.string()});
  ASSERT_TRUE(WaitForHops(out / "hops.csv", 2)) << Console();
  ASSERT_EQ(kill(pid_, SIGTERM), 0);
  EXPECT_EQ(Wait(), 4) << Console();
  EXPECT_NE(Console().find("interrupted by SIGTERM"), std::string::npos) << Console();
  EXPECT_GE(DataRows(out / "hops.csv"), 2);
  ExpectSummaryMatchesHops(out, "interrupted");
}

TEST_F(FaultTest, AFallEndsWithExitThreeAndEndFell) {
  const fs::path out = dir_ / "run";
  Start({Scenario("default.xml"), "--hops", "20", "--push", "1.5,-400,0.3", "-q", "--out",
         out.string()});
  EXPECT_EQ(Wait(), 3) << Console();
  EXPECT_NE(Console().find("the robot fell in hop"), std::string::npos) << Console();
  EXPECT_GE(DataRows(out / "hops.csv"), 1);
  ExpectSummaryMatchesHops(out, "fell");
}

TEST_F(FaultTest, ANonFiniteStateEndsWithExitSix) {
  // A finite but absurd push (1e300 N) makes MuJoCo's qacc huge: MuJoCo resets the state and
  // warns; the run must not go on from the reset state as if nothing happened.
  const fs::path out = dir_ / "run";
  Start({Scenario("default.xml"), "--hops", "20", "--push", "1.5,1e300,0.05", "-q", "--out",
         out.string()});
  EXPECT_EQ(Wait(), 6) << Console();
  EXPECT_NE(Console().find("non-finite state: MuJoCo found a NaN, Inf or huge value in qacc"),
            std::string::npos)
      << Console();
  EXPECT_GE(DataRows(out / "hops.csv"), 1);
  ExpectSummaryMatchesHops(out, "nonfinite_state");
  // MuJoCo's warning is on stderr, named, and not in a MUJOCO_LOG.TXT of the working directory.
  EXPECT_NE(Console().find("ddoc-hopper: MuJoCo warning: Nan, Inf or huge value in QACC"),
            std::string::npos)
      << Console();
  EXPECT_FALSE(fs::exists(dir_ / "MUJOCO_LOG.TXT"));
  // The logs end at the last finite state: no sample of MuJoCo's reset pose at t = 0.0005 s.
  EXPECT_NEAR(std::stod(Field(ReadFile(out / "summary.json"), "sim_time_s")), 1.5005, 1e-9);
  std::ifstream trajectory(out / "trajectory.csv");
  std::string line;
  std::getline(trajectory, line);
  double t_last = -1;
  int rows = 0;
  for (; std::getline(trajectory, line); ++rows) {
    const double t = std::stod(line.substr(0, line.find(',')));
    ASSERT_GT(t, t_last) << "row " << rows << ": " << line;
    t_last = t;
  }
  EXPECT_GT(rows, 0);
  EXPECT_NEAR(t_last, 1.5005, 1e-9);
}

TEST_F(FaultTest, AFileSizeLimitEndsWithExitFiveAndKeepsEveryHop) {
  // RLIMIT_FSIZE stands for a full disk: trajectory.csv (about 0.2 MB per hop) hits the limit
  // first; hops.csv, events.csv and summary.json stay below it.
  const fs::path out = dir_ / "run";
  Start({Scenario("default.xml"), "--hops", "50", "-q", "--out", out.string()}, 600 * 1024);
  EXPECT_EQ(Wait(), 5) << Console();
  EXPECT_NE(Console().find("cannot write \"" + (out / "trajectory.csv").string() +
                           "\": File too large"),
            std::string::npos)
      << Console();
  EXPECT_GE(DataRows(out / "hops.csv"), 1);
  ExpectSummaryMatchesHops(out, "io_error");
  EXPECT_NE(Field(ReadFile(out / "summary.json"), "end_message").find("trajectory.csv"),
            std::string::npos);
}

TEST_F(FaultTest, AnOutputDirectoryThatDisappearsEndsWithExitFive) {
  // The directory is moved away during the run (as root, permissions would not stop the run):
  // the open logs keep growing in the moved directory, the next summary.json cannot be written.
  const fs::path out = dir_ / "run";
  const fs::path moved = dir_ / "moved";
  Start({Scenario("default.xml"), "--hops", "1000", "-q", "--out", out.string()});
  ASSERT_TRUE(WaitForHops(out / "hops.csv", 2)) << Console();
  fs::rename(out, moved);
  EXPECT_EQ(Wait(), 5) << Console();
  EXPECT_NE(Console().find("cannot write \"" + (out / "summary.json.tmp").string()),
            std::string::npos)
      << Console();
  EXPECT_NE(Console().find("summary.json does not record the end (io_error)"), std::string::npos)
      << Console();
  EXPECT_GE(DataRows(moved / "hops.csv"), 2);
  ExpectConsecutiveHops(moved / "hops.csv");
}

}  // namespace
