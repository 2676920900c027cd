#include "core/executor.h"

#include <pthread.h>
#include <time.h>

#include <algorithm>

namespace stance {

namespace {
// the executor whose job this thread is running, and as which worker (nested run() calls)
thread_local const Executor* t_executor = nullptr;
thread_local int t_worker = 0;

// marks this thread as a worker of `executor` for its lifetime, then restores the outer mark
class WorkerMark {
 public:
  WorkerMark(const Executor* executor, int worker) : executor_(t_executor), worker_(t_worker) {
    t_executor = executor;
    t_worker = worker;
  }
  ~WorkerMark() {
    t_executor = executor_;
    t_worker = worker_;
  }
  WorkerMark(const WorkerMark&) = delete;
  WorkerMark& operator=(const WorkerMark&) = delete;

 private:
  const Executor* executor_;
  int worker_;
};
}  // namespace

Executor::Executor(int threads) {
  for (int w = 1; w < threads; ++w) threads_.emplace_back([this, w] { serve(w); });
  for (std::thread& t : threads_) {
    clockid_t clock;
    if (pthread_getcpuclockid(t.native_handle(), &clock) == 0) cpu_clocks_.push_back(clock);
  }
}

Executor::~Executor() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  for (auto& t : threads_) t.join();
}

void Executor::run(int n, const std::function<void(int, int)>& job) {
  if (n <= 0) return;
  // a job of this executor asking it for more work: the tasks run here, as that job's worker
  if (t_executor == this) {
    for (int task = 0; task < n; ++task) job(t_worker, task);
    return;
  }
  std::lock_guard<std::mutex> turn(run_mutex_);
  WorkerMark caller(this, 0);
  // the started threads join only when there is a task for them besides the caller's task 0
  const bool wake = n > 1 && !threads_.empty();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    job_ = &job;
    tasks_ = n;
    next_ = 1;  // task 0 is the calling thread's
    error_ = nullptr;
    busy_ = wake ? static_cast<int>(threads_.size()) : 0;
    if (wake) ++generation_;
  }
  if (wake) wake_.notify_all();
  run_task(job, 0, 0);
  take_tasks(0);
  std::exception_ptr error;
  {
    std::unique_lock<std::mutex> lock(mutex_);
    done_.wait(lock, [&] { return busy_ == 0; });
    job_ = nullptr;
    error = error_;
  }
  if (error) std::rethrow_exception(error);
}

void Executor::take_tasks(int worker) {
  for (;;) {
    const std::function<void(int, int)>* job;
    int task;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (next_ >= tasks_) return;
      task = next_++;
      job = job_;
    }
    run_task(*job, worker, task);
  }
}

void Executor::run_task(const std::function<void(int, int)>& job, int worker, int task) {
  try {
    job(worker, task);
  } catch (...) {
    // the first error wins; the tasks not yet started are dropped
    std::lock_guard<std::mutex> lock(mutex_);
    if (!error_) error_ = std::current_exception();
    next_ = tasks_;
  }
}

void Executor::serve(int worker) {
  WorkerMark mark(this, worker);
  long seen = 0;
  for (;;) {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [&] { return stop_ || generation_ != seen; });
      if (stop_) return;
      seen = generation_;
    }
    take_tasks(worker);
    std::lock_guard<std::mutex> lock(mutex_);
    if (--busy_ == 0) done_.notify_all();
  }
}

namespace {
double cpu_clock_seconds(clockid_t clock) {
  timespec t{};
  if (clock_gettime(clock, &t) != 0) return 0;
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}
}  // namespace

double Executor::started_threads_cpu_seconds() const {
  double sum = 0;
  for (clockid_t clock : cpu_clocks_) sum += cpu_clock_seconds(clock);
  return sum;
}

double thread_cpu_seconds() {
  return cpu_clock_seconds(CLOCK_THREAD_CPUTIME_ID);
}

int executor_threads(int requested, int tasks) {
  const int wanted =
      requested > 0 ? requested : static_cast<int>(std::thread::hardware_concurrency());
  return std::clamp(wanted, 1, std::max(1, tasks));
}

void run_parallel(int n, int threads, const std::function<void(int)>& job) {
  if (n <= 0) return;
  Executor executor(executor_threads(threads, n));
  executor.run(n, [&](int, int task) { job(task); });
}

}  // namespace stance
