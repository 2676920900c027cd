#include "core/atomic_file.h"

#include <fmt/format.h>
#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>

#include "core/error.h"

namespace stance {

namespace {
constexpr std::string_view kTag = ".stance-";
constexpr std::string_view kSuffix = ".tmp";

// the process id in ".name.stance-<pid>.tmp", or 0 when the name is not one of ours
long temporary_owner(const std::string& name) {
  if (name.size() < 2 || name[0] != '.' || !name.ends_with(kSuffix)) return 0;
  const size_t tag = name.rfind(kTag);
  if (tag == std::string::npos || tag == 0) return 0;
  const size_t digits = tag + kTag.size(), end = name.size() - kSuffix.size();
  if (digits >= end) return 0;
  long pid = 0;
  for (size_t i = digits; i < end; ++i) {
    if (name[i] < '0' || name[i] > '9' || pid > 1'000'000'000) return 0;
    pid = pid * 10 + (name[i] - '0');
  }
  return pid;
}
}  // namespace

std::filesystem::path temporary_path_for(const std::filesystem::path& path) {
  return path.parent_path() /
         fmt::format(".{}{}{}{}", path.filename().string(), kTag, getpid(), kSuffix);
}

int remove_stale_temporaries(const std::filesystem::path& dir) {
  std::error_code ec;
  const std::filesystem::path folder = dir.empty() ? "." : dir;
  std::filesystem::directory_iterator it(folder, ec), end;
  int removed = 0;
  for (; !ec && it != end; it.increment(ec)) {
    const long pid = temporary_owner(it->path().filename().string());
    if (pid <= 0 || pid == getpid()) continue;
    // kill(pid, 0) fails with ESRCH when no such process exists (EPERM: it runs as another user)
    if (kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;
    std::error_code ignored;
    if (std::filesystem::remove(it->path(), ignored)) ++removed;
  }
  return removed;
}

AtomicFile::AtomicFile(std::filesystem::path path, std::ios::openmode mode)
    : path_(std::move(path)), tmp_(temporary_path_for(path_)) {
  remove_stale_temporaries(path_.parent_path());
  out_.open(tmp_, mode | std::ios::out | std::ios::trunc);
  if (!out_) throw InputError(fmt::format("{}: cannot write", path_.string()));
  open_ = true;
}

AtomicFile::~AtomicFile() {
  discard();
}

void AtomicFile::discard() {
  if (!open_) return;
  open_ = false;
  out_.close();
  std::error_code ignored;
  std::filesystem::remove(tmp_, ignored);
}

void AtomicFile::commit() {
  if (!open_) throw InputError(fmt::format("{}: written twice", path_.string()));
  out_.flush();
  out_.close();
  if (!out_) {
    discard();
    throw InputError(fmt::format("{}: write failed", path_.string()));
  }
  open_ = false;
  std::error_code ec;
  std::filesystem::rename(tmp_, path_, ec);
  if (ec) {
    std::error_code ignored;
    std::filesystem::remove(tmp_, ignored);
    throw InputError(fmt::format("{}: cannot write ({})", path_.string(), ec.message()));
  }
}

void write_file_atomically(const std::filesystem::path& path, std::string_view content) {
  AtomicFile file(path);
  file.stream().write(content.data(), static_cast<std::streamsize>(content.size()));
  file.commit();
}

void rename_into_place(const std::filesystem::path& from, const std::filesystem::path& path) {
  std::error_code ec;
  std::filesystem::rename(from, path, ec);
  if (ec) {
    std::error_code ignored;
    std::filesystem::remove(from, ignored);
    throw InputError(fmt::format("{}: cannot write ({})", path.string(), ec.message()));
  }
}

}  // namespace stance
