// Files that are never torn: written to a hidden temporary name beside the target and renamed
// into place, so a reader (or a crash) sees the old complete file or the new one. The temporary
// carries the writer's process id ("dir/.name.stance-<pid>.tmp"), so one left by a killed run
// is told apart from a live run's and removed by the next writer into the same folder.
#pragma once

#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

namespace stance {

// the hidden temporary beside `path` for this process: "dir/.name.stance-<pid>.tmp"
std::filesystem::path temporary_path_for(const std::filesystem::path& path);

// remove the temporaries in `dir` left by stance processes that no longer run; returns how many
// (a live process's are left alone). Every AtomicFile calls it for its folder.
int remove_stale_temporaries(const std::filesystem::path& dir);

// a file written through a stream to its temporary and renamed into place by commit(); dropped
// without commit (an exception, an early return) it removes the temporary and leaves the old
// file as it was
class AtomicFile {
 public:
  explicit AtomicFile(std::filesystem::path path, std::ios::openmode mode = std::ios::binary);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  std::ostream& stream() { return out_; }
  const std::filesystem::path& path() const { return path_; }
  const std::filesystem::path& temporary() const { return tmp_; }
  // flush, close and rename into place; throws InputError naming the path on failure
  void commit();
  // close and remove the temporary (the target is left as it was)
  void discard();

 private:
  std::filesystem::path path_, tmp_;
  std::ofstream out_;
  bool open_ = false;
};

// write `content` to `path` atomically; throws InputError naming the path on failure
void write_file_atomically(const std::filesystem::path& path, std::string_view content);

// move a finished file (e.g. one a helper program wrote at `from`) into place at `path`
void rename_into_place(const std::filesystem::path& from, const std::filesystem::path& path);

}  // namespace stance
