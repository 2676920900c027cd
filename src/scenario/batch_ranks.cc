#include "scenario/batch_ranks.h"

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <stdexcept>
#include <vector>

#include "scenario/sweep.h"

#ifdef STANCE_HAVE_MPI
#include <mpi.h>
#endif

namespace stance {

bool launched_by_mpi() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK", "MPI_LOCALNRANKS"})
    if (std::getenv(name)) return true;
  return false;
}

BatchRanks& BatchRanks::get() {
  static BatchRanks ranks;
  return ranks;
}

BatchRanks::BatchRanks() {
#ifdef STANCE_HAVE_MPI
  if (!launched_by_mpi()) return;
  int already = 0;
  MPI_Initialized(&already);
  if (!already) {
    // only the calling thread talks to MPI; the worker threads never do
    int provided = 0;
    MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided);
    initialised_ = true;
  }
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
#endif
}

BatchRanks::~BatchRanks() {
#ifdef STANCE_HAVE_MPI
  int finalised = 0;
  MPI_Finalized(&finalised);
  if (initialised_ && !finalised) MPI_Finalize();
#endif
}

void BatchRanks::distributed_for(int n, int threads, const std::function<void(int)>& job,
                                 const std::function<std::string(int)>& encode,
                                 const std::function<void(int, const std::string&)>& decode,
                                 bool every_rank) {
  if (size_ == 1) {
    parallel_for(n, threads, job);
    return;
  }
#ifdef STANCE_HAVE_MPI
  std::vector<int> mine;
  for (int i = rank_; i < n; i += size_) mine.push_back(i);
  std::exception_ptr error;
  try {
    parallel_for(static_cast<int>(mine.size()), threads, [&](int k) { job(mine[k]); });
  } catch (...) {
    error = std::current_exception();
  }
  // this rank's results: (index, length, bytes) one after another
  std::string packed;
  for (int i : mine) {
    const std::string text = encode(i);
    const std::int64_t head[2] = {i, static_cast<std::int64_t>(text.size())};
    packed.append(reinterpret_cast<const char*>(head), sizeof(head));
    packed += text;
  }
  int failed = error ? 1 : 0, any_failed = 0;
  MPI_Allreduce(&failed, &any_failed, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  int length = static_cast<int>(packed.size());
  const bool receives = every_rank || root();
  std::vector<int> lengths(receives ? size_ : 0), offsets(receives ? size_ : 0);
  if (every_rank)
    MPI_Allgather(&length, 1, MPI_INT, lengths.data(), 1, MPI_INT, MPI_COMM_WORLD);
  else
    MPI_Gather(&length, 1, MPI_INT, lengths.data(), 1, MPI_INT, 0, MPI_COMM_WORLD);
  std::string all;
  if (receives) {
    int total = 0;
    for (int r = 0; r < size_; ++r) {
      offsets[r] = total;
      total += lengths[r];
    }
    all.resize(total);
  }
  if (every_rank)
    MPI_Allgatherv(packed.data(), length, MPI_CHAR, all.data(), lengths.data(), offsets.data(),
                   MPI_CHAR, MPI_COMM_WORLD);
  else
    MPI_Gatherv(packed.data(), length, MPI_CHAR, all.data(), lengths.data(), offsets.data(),
                MPI_CHAR, 0, MPI_COMM_WORLD);
  if (receives) {
    for (int r = 0; r < size_; ++r) {
      if (r == rank_) continue;
      size_t at = offsets[r];
      const size_t end = at + lengths[r];
      while (at < end) {
        std::int64_t head[2];
        std::memcpy(head, all.data() + at, sizeof(head));
        at += sizeof(head);
        decode(static_cast<int>(head[0]), all.substr(at, head[1]));
        at += head[1];
      }
    }
  }
  if (error) std::rethrow_exception(error);
  if (any_failed) throw std::runtime_error("batch work failed on another MPI rank");
#else
  parallel_for(n, threads, job);
#endif
}

}  // namespace stance
