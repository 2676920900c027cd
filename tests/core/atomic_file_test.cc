// Files that are never torn: the temporary beside the target, the rename, the old file kept on
// failure, and the temporaries of killed runs removed by the next writer.
#include "core/atomic_file.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "core/error.h"

namespace stance {
namespace {

namespace fs = std::filesystem;

fs::path fresh_dir(const std::string& name) {
  fs::path dir =
      fs::temp_directory_path() / "stance_tests" / (name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::string read(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

int count_entries(const fs::path& dir) {
  int n = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++n;
  return n;
}

TEST(AtomicFile, TemporaryIsHiddenBesideTheTargetAndNamesTheProcess) {
  fs::path tmp = temporary_path_for("/a/b/log.csv");
  EXPECT_EQ(tmp.parent_path(), fs::path("/a/b"));
  EXPECT_EQ(tmp.filename().string(), ".log.csv.stance-" + std::to_string(::getpid()) + ".tmp");
}

TEST(AtomicFile, CommitRenamesIntoPlaceAndDropKeepsTheOldFile) {
  fs::path dir = fresh_dir("atomic_commit");
  write_file_atomically(dir / "a.txt", "old\n");
  EXPECT_EQ(read(dir / "a.txt"), "old\n");
  {
    AtomicFile f(dir / "a.txt");
    f.stream() << "half of a new";
    // mid-write: the target is still the old file, the new text sits in the temporary
    EXPECT_EQ(read(dir / "a.txt"), "old\n");
    EXPECT_TRUE(fs::exists(f.temporary()));
  }  // dropped without commit (an exception on the way)
  EXPECT_EQ(read(dir / "a.txt"), "old\n");
  EXPECT_EQ(count_entries(dir), 1);
  {
    AtomicFile f(dir / "a.txt");
    f.stream() << "new\n";
    f.commit();
  }
  EXPECT_EQ(read(dir / "a.txt"), "new\n");
  EXPECT_EQ(count_entries(dir), 1);
  // a target that cannot be replaced (a folder) is an InputError naming it, and no temporary
  fs::create_directories(dir / "sub");
  try {
    write_file_atomically(dir / "sub", "x");
    ADD_FAILURE() << "wrote over a folder";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find((dir / "sub").string() + ": cannot write ("),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(count_entries(dir), 2);
  fs::remove_all(dir);
}

TEST(AtomicFile, NextWriterRemovesTemporariesOfDeadProcessesOnly) {
  fs::path dir = fresh_dir("atomic_stale");
  // above any pid_max (4194304 at most on Linux): no such process
  const fs::path dead = dir / ".log.csv.stance-999999999.tmp";
  const fs::path live = dir / (".log.csv.stance-" + std::to_string(::getppid()) + ".tmp");
  const fs::path other = dir / ".notes.tmp";  // not one of ours
  for (const auto& p : {dead, live, other}) std::ofstream(p) << "partial";
  write_file_atomically(dir / "summary.json", "{}\n");
  EXPECT_FALSE(fs::exists(dead));
  EXPECT_TRUE(fs::exists(live));
  EXPECT_TRUE(fs::exists(other));
  EXPECT_EQ(remove_stale_temporaries(dir), 0);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace stance
