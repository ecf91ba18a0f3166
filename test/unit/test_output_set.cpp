// OutputSet: a directory's result files replaced as one set, with `complete` written last.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "novelty_detection/io/output_set.h"
#include "temp_dir.h"

namespace fs = std::filesystem;
using novelty_detection::OutputSet;

namespace {

fs::path tempDir(const std::string& name) { return test_helpers::freshTempDir("set", name); }

std::string readFile(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::vector<std::string> entries(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename());
  std::sort(names.begin(), names.end());
  return names;
}

std::vector<std::string> listed(const fs::path& dir) {
  std::ifstream in(dir / OutputSet::kMarker);
  std::vector<std::string> names;
  for (std::string n; std::getline(in, n);) names.push_back(n);
  return names;
}

/// Writes a set of `files` files, each holding `run`.
void writeSet(const fs::path& dir, int run, int files) {
  OutputSet set(dir.string());
  for (int i = 0; i < files; ++i)
    set.writeText("f" + std::to_string(i) + ".txt", std::to_string(run));
  set.commit();
}

}  // namespace

TEST(OutputSet, CommitReplacesTheSetAndListsIt) {
  const fs::path dir = tempDir("commit");
  {
    OutputSet set(dir.string());
    set.writeText("a.txt", "1");
    set.writeText("b.txt", "1");
    // Nothing is visible before the commit.
    EXPECT_FALSE(fs::exists(dir / "a.txt"));
    set.commit();
  }
  EXPECT_EQ(entries(dir), (std::vector<std::string>{"a.txt", "b.txt", "complete"}));
  EXPECT_EQ(listed(dir), (std::vector<std::string>{"a.txt", "b.txt"}));
  // A smaller set replaces it whole: b.txt of the old set does not stay.
  {
    OutputSet set(dir.string());
    set.writeText("a.txt", "2");
    set.commit();
  }
  EXPECT_EQ(entries(dir), (std::vector<std::string>{"a.txt", "complete"}));
  EXPECT_EQ(readFile(dir / "a.txt"), "2");
  fs::remove_all(dir);
}

TEST(OutputSet, AnUncommittedSetLeavesThePreviousOne) {
  const fs::path dir = tempDir("abandon");
  writeSet(dir, 1, 3);
  {
    OutputSet set(dir.string());
    set.writeText("f0.txt", "2");
    // Destroyed without a commit (an exception in the run): the old set stands.
  }
  EXPECT_EQ(entries(dir), (std::vector<std::string>{"complete", "f0.txt", "f1.txt", "f2.txt"}));
  EXPECT_EQ(readFile(dir / "f0.txt"), "1");
  // A process killed before its commit leaves its staging directory; the next set removes it.
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    OutputSet set(dir.string());
    set.writeText("f0.txt", "3");
    ::_exit(0);  // no destructor, no commit: as a SIGKILL would leave it
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  EXPECT_EQ(entries(dir).size(), 5u);  // the dead process's staging directory
  EXPECT_EQ(readFile(dir / "f0.txt"), "1");
  writeSet(dir, 4, 2);
  EXPECT_EQ(entries(dir), (std::vector<std::string>{"complete", "f0.txt", "f1.txt"}));
  fs::remove_all(dir);
}

// Killed at arbitrary moments while replacing a 200-file set: whenever `complete` is present,
// every file it lists exists and comes from one run.
TEST(OutputSet, AKillNeverLeavesAMixedCompleteSet) {
  const fs::path dir = tempDir("kill");
  writeSet(dir, 0, 200);
  // Kills spread over the second half of one set's writing time, where the renames are.
  const auto t0 = std::chrono::steady_clock::now();
  writeSet(dir, 0, 200);
  const double whole_us =
      std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
  int old_seen = 0, new_seen = 0, interrupted_seen = 0;
  constexpr int kAttempts = 40;
  for (int attempt = 1; attempt <= kAttempts; ++attempt) {
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      writeSet(dir, attempt, 200);
      ::_exit(0);
    }
    const double at = whole_us * (0.5 + 0.6 * attempt / kAttempts);
    std::this_thread::sleep_for(std::chrono::microseconds(static_cast<long>(at)));
    ::kill(child, SIGKILL);
    int status = 0;
    ASSERT_EQ(::waitpid(child, &status, 0), child);
    if (!fs::exists(dir / OutputSet::kMarker)) {
      ++interrupted_seen;
      writeSet(dir, 0, 200);  // the next run restores a complete set
      continue;
    }
    const std::vector<std::string> names = listed(dir);
    ASSERT_EQ(names.size(), 200u);
    const std::string run = readFile(dir / names[0]);
    for (const std::string& n : names) ASSERT_EQ(readFile(dir / n), run) << n;
    if (run == std::to_string(attempt)) {
      ++new_seen;
    } else {
      ++old_seen;
    }
    writeSet(dir, 0, 200);
  }
  std::printf("one set %.0f us; kills left the old set %d, the new set %d, no set %d times\n",
              whole_us, old_seen, new_seen, interrupted_seen);
  EXPECT_EQ(old_seen + new_seen + interrupted_seen, kAttempts);
  fs::remove_all(dir);
}

TEST(OutputSet, APlantedSymlinkIsReplacedNotFollowed) {
  const fs::path dir = tempDir("link");
  const fs::path victim = dir / "victim.txt";
  std::ofstream(victim) << "keep";
  const fs::path out = dir / "out";
  fs::create_directories(out);
  fs::create_symlink(victim, out / "labels.txt");
  {
    OutputSet set(out.string());
    set.writeText("labels.txt", "new");
    set.commit();
  }
  EXPECT_EQ(readFile(victim), "keep");
  EXPECT_FALSE(fs::is_symlink(out / "labels.txt"));
  EXPECT_EQ(readFile(out / "labels.txt"), "new");
  fs::remove_all(dir);
}

TEST(OutputSet, RefusesNamesThatAreNotPlainFiles) {
  const fs::path dir = tempDir("names");
  OutputSet set(dir.string());
  for (const char* bad : {"", "../x", "a/b", ".hidden", "complete"})
    EXPECT_THROW(set.stagedPath(bad), std::invalid_argument) << bad;
  // A path that is a file, not a directory.
  std::ofstream(dir / "file") << "x";
  EXPECT_THROW(OutputSet((dir / "file").string()), std::runtime_error);
  fs::remove_all(dir);
}
