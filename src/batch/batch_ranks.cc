#include "batch/batch_ranks.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <exception>
#include <limits>
#include <mutex>
#include <stdexcept>
#include <vector>

#include "core/executor.h"

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
// (MPI_THREAD_FUNNELED): the dispatch is the executor's task 0, which runs on the calling thread,
// and tasks 1..workers are the workers' loops. Each item's result depends on its index alone, so
// the files do not depend on who ran what. Returns the indices this rank ran; the first job
// exception is kept in `error` and later items are skipped (their results do not count: every
// rank throws).
class SelfScheduled {
 public:
  SelfScheduled(int n, int rank, int size, int workers, const std::function<void(int)>& job)
      : n_(n), rank_(rank), size_(size), workers_(workers), job_(job) {}

  std::vector<int> run(std::exception_ptr& error) {
    Executor executor(workers_ + 1);
    executor.run(workers_ + 1, [&](int, int task) {
      if (task == 0)
        dispatch();
      else
        work();
    });
    error = error_;
    std::sort(ran_.begin(), ran_.end());
    return ran_;
  }

 private:
  // a worker's loop: the queued indices until the dispatch says there are no more
  void work() {
    for (;;) {
      int i;
      bool skip;
      {
        std::unique_lock<std::mutex> lock(m_);
        work_cv_.wait(lock, [&] { return !queue_.empty() || no_more_; });
        if (queue_.empty()) return;
        i = queue_.front();
        queue_.pop_front();
        ++busy_;
        skip = static_cast<bool>(error_);
      }
      std::exception_ptr failed;
      if (!skip) {
        try {
          job_(i);
        } catch (...) {
          failed = std::current_exception();
        }
      }
      {
        std::lock_guard<std::mutex> lock(m_);
        if (failed && !error_) error_ = failed;
        ran_.push_back(i);
        --busy_;
      }
      main_cv_.notify_one();
    }
  }

  // the next index for this rank (n: none left)
  int take() {
    if (rank_ == 0) return next_ < n_ ? next_++ : n_;
    int ask = 1, given = n_;
    MPI_Send(&ask, 1, MPI_INT, 0, kAskTag, MPI_COMM_WORLD);
    MPI_Recv(&given, 1, MPI_INT, 0, kGiveTag, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    return given;
  }

  // rank 0: answers every waiting request from another rank
  void answer_requests() {
    for (int flag = 1; flag;) {
      MPI_Status status;
      MPI_Iprobe(MPI_ANY_SOURCE, kAskTag, MPI_COMM_WORLD, &flag, &status);
      if (!flag) break;
      int ask = 0;
      MPI_Recv(&ask, 1, MPI_INT, status.MPI_SOURCE, kAskTag, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
      const int given = next_ < n_ ? next_++ : n_;
      if (given == n_) ++ranks_told_done_;
      MPI_Send(&given, 1, MPI_INT, status.MPI_SOURCE, kGiveTag, MPI_COMM_WORLD);
    }
  }

  // the calling thread: keeps this rank's workers fed and (rank 0) the other ranks answered
  void dispatch() {
    for (;;) {
      if (rank_ == 0) answer_requests();
      std::unique_lock<std::mutex> lock(m_);
      // keep every worker busy; no index waits here while another rank could take it
      while (!exhausted_ && static_cast<int>(queue_.size()) + busy_ < workers_) {
        lock.unlock();
        const int i = take();
        lock.lock();
        if (i >= n_) {
          exhausted_ = true;
          no_more_ = true;
        } else {
          queue_.push_back(i);
        }
        work_cv_.notify_all();
      }
      const bool idle = exhausted_ && queue_.empty() && busy_ == 0;
      if (idle && (rank_ != 0 || ranks_told_done_ == size_ - 1)) break;
      // rank 0 polls for requests; the others wait for a worker to finish
      main_cv_.wait_for(lock, std::chrono::microseconds(rank_ == 0 ? 200 : 20000));
    }
    std::lock_guard<std::mutex> lock(m_);
    no_more_ = true;
    work_cv_.notify_all();
  }

  const int n_, rank_, size_, workers_;
  const std::function<void(int)>& job_;
  std::mutex m_;
  std::condition_variable work_cv_, main_cv_;
  std::deque<int> queue_;
  int busy_ = 0;
  bool no_more_ = false;
  std::vector<int> ran_;
  std::exception_ptr error_;
  int next_ = 0;             // rank 0: the next unstarted index
  int ranks_told_done_ = 0;  // rank 0: ranks that got the end mark
  bool exhausted_ = false;   // this rank got an index >= n
};
}  // namespace
#endif

void BatchRanks::distributed_for(int n, int threads, const std::function<void(int)>& job,
                                 const std::function<std::string(int)>& encode,
                                 const std::function<void(int, const std::string&)>& decode,
                                 bool every_rank) {
  if (size_ == 1) {
    run_parallel(n, threads, job);
    return;
  }
#ifdef STANCE_HAVE_MPI
  std::exception_ptr error;
  const int workers = executor_threads(threads, std::numeric_limits<int>::max());
  const std::vector<int> mine = SelfScheduled(n, rank_, size_, workers, job).run(error);
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
  run_parallel(n, threads, job);
#endif
}

}  // namespace stance
