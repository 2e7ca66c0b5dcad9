#pragma once
/// @file
/// @brief Independent tasks spread over threads, with the result independent of their number.

#include <Eigen/Core>

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

#if defined(__linux__)
#include <sched.h>
#endif

namespace sid {
namespace detail {

/// The cores this process may run on. std::thread::hardware_concurrency() counts the machine's
/// online cores, which in a container limited to a few of a large host's cores is many times
/// what the process gets; there every extra thread only adds its start and its share of switches.
inline int available_cores() {
#if defined(__linux__)
  cpu_set_t cores;
  CPU_ZERO(&cores);
  if (sched_getaffinity(0, sizeof(cores), &cores) == 0) return std::max(1, CPU_COUNT(&cores));
#endif
  return static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

/// The threads a `threads` option asks for: the number if positive, otherwise every core this
/// process may run on.
inline int thread_count(int requested) { return requested > 0 ? requested : available_cores(); }

/// Calls f(i, thread) for i in [0, count), in increasing order of i, on up to `threads` threads
/// (thread 0 is the caller's). After an exception in f no further task starts; it is rethrown
/// once the running tasks finished.
template <typename F>
void for_each_index(Eigen::Index count, int threads, const F& f) {
  if (threads <= 1 || count <= 1) {
    for (Eigen::Index i = 0; i < count; ++i) f(i, 0);
    return;
  }
  std::atomic<Eigen::Index> next{0};
  std::exception_ptr error;
  std::mutex error_mutex;
  const auto work = [&](int thread) {
    for (Eigen::Index i = next++; i < count; i = next++) {
      try {
        f(i, thread);
      } catch (...) {
        const std::lock_guard<std::mutex> lock(error_mutex);
        if (!error) error = std::current_exception();
        next = count;
      }
    }
  };
  // A thread beyond the task count would find no task: none is started.
  const auto started = static_cast<int>(std::min<Eigen::Index>(threads, count));
  std::vector<std::thread> pool;
  for (int t = 1; t < started; ++t) pool.emplace_back(work, t);
  work(0);
  for (auto& t : pool) t.join();
  if (error) std::rethrow_exception(error);
}

}  // namespace detail
}  // namespace sid
