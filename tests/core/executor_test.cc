#include "core/executor.h"

#include <gtest/gtest.h>
#include <time.h>

#include <algorithm>
#include <atomic>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace stance {
namespace {

// every task exactly once, on a worker in range, however many tasks and workers, and a pool
// reused for several batches
TEST(Executor, RunsEveryTaskOnceOnAWorkerInRange) {
  for (int threads : {1, 2, 4}) {
    Executor executor(threads);
    ASSERT_EQ(executor.size(), threads);
    for (int n : {0, 1, 2, 3, 17, 200}) {
      std::vector<std::atomic<int>> runs(n);
      std::atomic<int> bad_worker{0};
      executor.run(n, [&](int worker, int task) {
        if (worker < 0 || worker >= threads) ++bad_worker;
        ++runs[task];
      });
      EXPECT_EQ(bad_worker.load(), 0);
      for (int i = 0; i < n; ++i) EXPECT_EQ(runs[i].load(), 1) << "task " << i << " of " << n;
    }
  }
}

// task 0 is the caller's (batch_ranks talks to MPI from there), as worker 0
TEST(Executor, TaskZeroRunsOnTheCallingThread) {
  Executor executor(3);
  const std::thread::id caller = std::this_thread::get_id();
  for (int repeat = 0; repeat < 20; ++repeat) {
    std::thread::id ran_on;
    int as_worker = -1;
    executor.run(8, [&](int worker, int task) {
      if (task != 0) return;
      ran_on = std::this_thread::get_id();
      as_worker = worker;
    });
    EXPECT_EQ(ran_on, caller);
    EXPECT_EQ(as_worker, 0);
  }
}

// a bug in a job reaches the caller, on its own thread, with its message, and stops the tasks
// not yet started; the pool stays usable
TEST(Executor, AnExceptionIsRethrownOnTheCaller) {
  for (int threads : {1, 2, 4}) {
    Executor executor(threads);
    std::atomic<int> ran{0};
    try {
      executor.run(1000, [&](int, int task) {
        ++ran;
        if (task == 3) throw std::logic_error("a bug in task 3");
      });
      ADD_FAILURE() << "no exception";
    } catch (const std::logic_error& e) {
      EXPECT_EQ(std::string(e.what()), "a bug in task 3");
    }
    EXPECT_GE(ran.load(), 4);
    EXPECT_LT(ran.load(), 1000);
    std::atomic<int> after{0};
    executor.run(10, [&](int, int) { ++after; });
    EXPECT_EQ(after.load(), 10);
  }
  EXPECT_THROW(run_parallel(5, 2,
                            [](int task) {
                              if (task == 4) throw std::runtime_error("last");
                            }),
               std::runtime_error);
}

// a job that asks its own executor for more work runs it itself, as its own worker
TEST(Executor, NestedRunOnTheSameExecutorRunsOnTheJobsThread) {
  Executor executor(3);
  std::vector<std::atomic<int>> inner(4 * 5);
  std::atomic<int> wrong_worker{0};
  executor.run(4, [&](int outer_worker, int outer_task) {
    const std::thread::id here = std::this_thread::get_id();
    executor.run(5, [&](int worker, int task) {
      if (worker != outer_worker || std::this_thread::get_id() != here) ++wrong_worker;
      ++inner[outer_task * 5 + task];
    });
  });
  EXPECT_EQ(wrong_worker.load(), 0);
  for (auto& count : inner) EXPECT_EQ(count.load(), 1);
}

// a batch whose jobs each own an executor (clips whose runs plan on threads)
TEST(Executor, JobsMayOwnExecutorsOfTheirOwn) {
  Executor batch(2);
  std::vector<std::atomic<int>> rollouts(3 * 16);
  batch.run(3, [&](int, int clip) {
    Executor planner(2);
    for (int step = 0; step < 4; ++step)
      planner.run(4, [&](int worker, int candidate) {
        ASSERT_LT(worker, planner.size());
        ++rollouts[clip * 16 + step * 4 + candidate];
      });
  });
  for (auto& count : rollouts) EXPECT_EQ(count.load(), 1);
}

// two threads that share an executor take turns: no task of one batch runs during the other's
TEST(Executor, TwoCallersTakeTurns) {
  Executor executor(2);
  std::atomic<int> active[2] = {0, 0};
  std::atomic<int> overlaps{0}, total{0};
  auto batch = [&](int me) {
    for (int repeat = 0; repeat < 50; ++repeat)
      executor.run(6, [&](int, int) {
        ++active[me];
        if (active[1 - me].load() != 0) ++overlaps;
        ++total;
        --active[me];
      });
  };
  std::thread other(batch, 1);
  batch(0);
  other.join();
  EXPECT_EQ(overlaps.load(), 0);
  EXPECT_EQ(total.load(), 2 * 50 * 6);
}

TEST(Executor, ThreadCountForAJob) {
  EXPECT_EQ(executor_threads(4, 10), 4);
  EXPECT_EQ(executor_threads(4, 2), 2);
  EXPECT_EQ(executor_threads(3, 0), 1);
  EXPECT_EQ(executor_threads(-1, 1), 1);
  const int cores = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  EXPECT_EQ(executor_threads(0, 1000), std::min(cores, 1000));
}

// spins until the calling thread has used `seconds` more of its own CPU
void burn_cpu(double seconds) {
  const double start = thread_cpu_seconds();
  while (thread_cpu_seconds() - start < seconds) {
  }
}

// a thread's CPU clock counts that thread alone: the caller waits while another thread works
TEST(Executor, ThreadCpuCountsTheCallingThreadAlone) {
  const double start = thread_cpu_seconds();
  std::thread other([] { burn_cpu(0.05); });
  other.join();
  EXPECT_LT(thread_cpu_seconds() - start, 0.02);
  burn_cpu(0.02);
  EXPECT_GE(thread_cpu_seconds() - start, 0.02);
}

// the started threads' CPU holds every task they ran (each spins 20 ms of its thread's CPU) and
// no more than the process used besides the caller
TEST(Executor, StartedThreadsCpuHoldsTheirTasks) {
  Executor executor(3);
  const double started0 = executor.started_threads_cpu_seconds();
  const double caller0 = thread_cpu_seconds();
  timespec process0{}, process1{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &process0);
  std::atomic<int> on_started{0};
  executor.run(8, [&](int worker, int) {
    burn_cpu(0.02);
    on_started += worker > 0;
  });
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &process1);
  const double started = executor.started_threads_cpu_seconds() - started0;
  const double others = (process1.tv_sec - process0.tv_sec) +
                        1e-9 * (process1.tv_nsec - process0.tv_nsec) -
                        (thread_cpu_seconds() - caller0);
  EXPECT_GE(started, 0.02 * on_started.load());
  EXPECT_LE(started, others + 1e-3);
  EXPECT_EQ(Executor(1).started_threads_cpu_seconds(), 0);
}
}  // namespace
}  // namespace stance
