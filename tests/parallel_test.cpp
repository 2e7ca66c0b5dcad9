#include <sid/detail/parallel.hpp>

#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>
#include <vector>

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
