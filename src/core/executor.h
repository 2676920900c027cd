// One fixed pool of threads for every parallel job in stance: the planner's rollouts, the runs of
// a sweep, a tune or a robustness map, the push search's two directions and a batch's clips (MPI
// ranks, in src/batch/batch_ranks.h, hand out work on top of it).
//
// run(n, job) calls job(worker, task) exactly once for every task in [0, n) and returns when all
// are done. Workers are numbered [0, size()); the calling thread is worker 0 and runs task 0
// itself, so work that must stay on the caller's thread (MPI calls under MPI_THREAD_FUNNELED)
// can be task 0. Which worker runs which other task is not fixed: a task's result must depend on
// its index alone (seed per unit of work), never on the worker or the order.
//
// Errors: the first exception thrown by a job stops the tasks not yet started and is rethrown on
// the calling thread once the started ones have finished.
//
// Nesting:
//  - a job may make and use an Executor of its own (a batch of clips whose runs each plan on
//    threads: every planner owns one); the threads add up, so the outer batch divides them;
//  - a job that calls run() on the executor it is running in gets those tasks run one after
//    another on its own thread, as its own worker (no deadlock, no extra threads);
//  - two threads that call run() on one executor at the same time take turns.
#pragma once

#include <time.h>

#include <condition_variable>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace stance {

class Executor {
 public:
  // threads >= 1 workers, the calling thread included (threads - 1 are started here)
  explicit Executor(int threads);
  ~Executor();
  Executor(const Executor&) = delete;
  Executor& operator=(const Executor&) = delete;

  int size() const { return static_cast<int>(threads_.size()) + 1; }
  // CPU seconds the started threads (workers 1 and up) have used since they started; worker 0's
  // share is on the calling thread's own clock (thread_cpu_seconds)
  double started_threads_cpu_seconds() const;

  // job(worker, task) for every task in [0, n), worker in [0, size()); see the top of the file
  void run(int n, const std::function<void(int worker, int task)>& job);

 private:
  void serve(int worker);       // a started thread's loop
  void take_tasks(int worker);  // runs tasks until none is left
  void run_task(const std::function<void(int, int)>& job, int worker, int task);
  std::vector<std::thread> threads_;
  std::vector<clockid_t> cpu_clocks_;  // the started threads' CPU clocks
  std::mutex run_mutex_;               // one run() at a time
  std::mutex mutex_;                   // guards what follows
  std::condition_variable wake_, done_;
  const std::function<void(int, int)>* job_ = nullptr;
  int tasks_ = 0, next_ = 0, busy_ = 0;
  long generation_ = 0;
  bool stop_ = false;
  std::exception_ptr error_;
};

// CPU seconds the calling thread has used (its own clock, not the process's: right when other
// runs share the process)
double thread_cpu_seconds();

// the workers for `tasks` tasks when `requested` threads are asked for: `requested` (0 or less:
// every core), at most `tasks`, at least 1
int executor_threads(int requested, int tasks);

// job(task) for every task in [0, n) on an Executor of executor_threads(threads, n) workers made
// for this call; the first exception is rethrown here
void run_parallel(int n, int threads, const std::function<void(int task)>& job);

}  // namespace stance
