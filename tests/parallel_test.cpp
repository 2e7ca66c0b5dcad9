#include <sid/detail/parallel.hpp>

#include <gtest/gtest.h>

#include <atomic>
#include <mutex>
#include <set>
#include <stdexcept>
#include <vector>

#if defined(__linux__)
#include <sched.h>
#endif

TEST(Parallel, EveryIndexRunsOnceForAnyThreadCount) {
  for (int threads : {1, 2, 3, 8}) {
    std::vector<int> calls(100, 0);
    sid::detail::for_each_index(100, threads, [&](Eigen::Index i, int thread) {
      EXPECT_GE(thread, 0);
      EXPECT_LT(thread, threads);
      ++calls[static_cast<std::size_t>(i)];  // each index is handed out once: no data race
    });
    for (int c : calls) EXPECT_EQ(c, 1) << threads << " threads";
  }
}

TEST(Parallel, AnExceptionIsRethrownAndStopsFurtherTasks) {
  for (int threads : {1, 2}) {
    std::atomic<int> started{0};
    EXPECT_THROW(sid::detail::for_each_index(1000, threads,
                                             [&](Eigen::Index i, int) {
                                               ++started;
                                               if (i == 3) throw std::runtime_error("task 3");
                                             }),
                 std::runtime_error);
    // Tasks already handed out may finish; the rest of the 1000 never start.
    EXPECT_LT(started.load(), 1000) << threads << " threads";
  }
}

TEST(Parallel, ThreadCountIsTheRequestOrEveryCore) {
  EXPECT_EQ(sid::detail::thread_count(3), 3);
  EXPECT_GE(sid::detail::thread_count(0), 1);
  EXPECT_EQ(sid::detail::thread_count(-1), sid::detail::thread_count(0));
}

#if defined(__linux__)
TEST(Parallel, EveryCoreMeansTheCoresThisProcessMayRunOn) {
  cpu_set_t all;
  ASSERT_EQ(sched_getaffinity(0, sizeof(all), &all), 0);
  EXPECT_EQ(sid::detail::thread_count(0), CPU_COUNT(&all));
  // Pinned to one core, the process is offered one thread, whatever the machine has.
  int first = 0;
  while (!CPU_ISSET(first, &all)) ++first;
  cpu_set_t one;
  CPU_ZERO(&one);
  CPU_SET(first, &one);
  ASSERT_EQ(sched_setaffinity(0, sizeof(one), &one), 0);
  const int pinned = sid::detail::thread_count(0);
  ASSERT_EQ(sched_setaffinity(0, sizeof(all), &all), 0);
  EXPECT_EQ(pinned, 1);
}
#endif

TEST(Parallel, NoMoreThreadsStartThanThereAreTasks) {
  // Two tasks on sixteen threads asked for: only workers 0 and 1 may exist. Repeated, since a
  // thread too many takes a task only when it is quicker than the others.
  std::mutex mutex;
  std::set<int> workers;
  for (int repeat = 0; repeat < 50; ++repeat)
    sid::detail::for_each_index(2, 16, [&](Eigen::Index, int worker) {
      const std::lock_guard<std::mutex> lock(mutex);
      workers.insert(worker);
    });
  for (int w : workers) EXPECT_LT(w, 2);
}
