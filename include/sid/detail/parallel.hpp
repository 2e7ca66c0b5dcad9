#pragma once
/// @file
/// @brief Independent tasks spread over threads, with the result independent of their number.

#include <Eigen/Core>

#include <atomic>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace sid {
namespace detail {

/// Calls f(i, thread) for i in [0, count) on up to `threads` threads (thread 0 is the caller's).
/// An exception in f is rethrown after all threads finished.
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
      }
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(work, t);
  work(0);
  for (auto& t : pool) t.join();
  if (error) std::rethrow_exception(error);
}

}  // namespace detail
}  // namespace sid
