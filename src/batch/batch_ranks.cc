#include "batch/batch_ranks.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <exception>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <vector>

#include "batch/sweep.h"

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

#ifdef STANCE_HAVE_MPI
namespace {
constexpr int kAskTag = 7101, kGiveTag = 7102;

// Self-scheduling over ranks: rank 0 holds the next unstarted index; its own workers take from
// it directly and its calling thread hands indices to the other ranks on request, so a rank
// whose runs end early (a fall) takes more. Only the calling threads talk to MPI
// (MPI_THREAD_FUNNELED). Each item's result depends on its index alone, so the files do not
// depend on who ran what. Returns the indices this rank ran; the first job exception is kept
// in `error` and later items are skipped (their results do not count: every rank throws).
std::vector<int> run_self_scheduled(int n, int threads, int rank, int size,
                                    const std::function<void(int)>& job,
                                    std::exception_ptr& error) {
  const int workers =
      std::max(1, threads > 0 ? threads : static_cast<int>(std::thread::hardware_concurrency()));
  std::mutex m;
  std::condition_variable work_cv, main_cv;
  std::deque<int> queue;
  int busy = 0;
  bool no_more = false;
  std::vector<int> ran;
  auto worker = [&]() {
    for (;;) {
      int i;
      {
        std::unique_lock<std::mutex> lock(m);
        work_cv.wait(lock, [&] { return !queue.empty() || no_more; });
        if (queue.empty()) return;
        i = queue.front();
        queue.pop_front();
        ++busy;
      }
      bool skip;
      {
        std::lock_guard<std::mutex> lock(m);
        skip = static_cast<bool>(error);
      }
      std::exception_ptr failed;
      if (!skip) {
        try {
          job(i);
        } catch (...) {
          failed = std::current_exception();
        }
      }
      {
        std::lock_guard<std::mutex> lock(m);
        if (failed && !error) error = failed;
        ran.push_back(i);
        --busy;
      }
      main_cv.notify_one();
    }
  };
  std::vector<std::thread> pool;
  for (int k = 0; k < workers; ++k) pool.emplace_back(worker);

  int next = 0;             // rank 0: the next unstarted index
  int ranks_told_done = 0;  // rank 0: ranks that got the end mark
  bool exhausted = false;   // this rank got an index >= n
  auto take = [&]() -> int {
    if (rank == 0) return next < n ? next++ : n;
    int ask = 1, given = n;
    MPI_Send(&ask, 1, MPI_INT, 0, kAskTag, MPI_COMM_WORLD);
    MPI_Recv(&given, 1, MPI_INT, 0, kGiveTag, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    return given;
  };
  for (;;) {
    if (rank == 0) {
      // answer every waiting request from another rank
      for (int flag = 1; flag;) {
        MPI_Status status;
        MPI_Iprobe(MPI_ANY_SOURCE, kAskTag, MPI_COMM_WORLD, &flag, &status);
        if (!flag) break;
        int ask = 0;
        MPI_Recv(&ask, 1, MPI_INT, status.MPI_SOURCE, kAskTag, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        const int given = next < n ? next++ : n;
        if (given == n) ++ranks_told_done;
        MPI_Send(&given, 1, MPI_INT, status.MPI_SOURCE, kGiveTag, MPI_COMM_WORLD);
      }
    }
    {
      std::unique_lock<std::mutex> lock(m);
      // keep every worker busy; no index waits here while another rank could take it
      while (!exhausted && static_cast<int>(queue.size()) + busy < workers) {
        lock.unlock();
        const int i = take();
        lock.lock();
        if (i >= n) {
          exhausted = true;
          no_more = true;
        } else {
          queue.push_back(i);
        }
        work_cv.notify_all();
      }
      const bool idle = exhausted && queue.empty() && busy == 0;
      if (idle && (rank != 0 || ranks_told_done == size - 1)) break;
      // rank 0 polls for requests; the others wait for a worker to finish
      main_cv.wait_for(lock, std::chrono::microseconds(rank == 0 ? 200 : 20000));
    }
  }
  work_cv.notify_all();
  for (auto& t : pool) t.join();
  std::sort(ran.begin(), ran.end());
  return ran;
}
}  // namespace
#endif

void BatchRanks::distributed_for(int n, int threads, const std::function<void(int)>& job,
                                 const std::function<std::string(int)>& encode,
                                 const std::function<void(int, const std::string&)>& decode,
                                 bool every_rank) {
  if (size_ == 1) {
    parallel_for(n, threads, job);
    return;
  }
#ifdef STANCE_HAVE_MPI
  std::exception_ptr error;
  const std::vector<int> mine = run_self_scheduled(n, threads, rank_, size_, job, error);
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
