// A fixed set of threads that run one job at a time, each with its worker index; the calling
// thread is worker 0. Nothing is allocated per job (the job is a function pointer and a context).
#pragma once

#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <thread>
#include <vector>

namespace rsrio::sim::detail {

class WorkerPool {
 public:
  explicit WorkerPool(int threads) {
    const int n = threads < 1 ? 1 : threads;
    for (int i = 1; i < n; ++i) threads_.emplace_back([this, i] { loop(i); });
  }
  ~WorkerPool() {
    {
      std::lock_guard lock(mutex_);
      stop_ = true;
    }
    start_.notify_all();
    for (auto& t : threads_) t.join();
  }
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  int size() const { return static_cast<int>(threads_.size()) + 1; }

  /// Runs f(worker) on every worker, worker in [0, size()), and returns when all are done.
  template <typename F>
  void run(F& f) {
    run_impl([](void* ctx, int worker) { (*static_cast<F*>(ctx))(worker); }, &f);
  }

 private:
  void run_impl(void (*fn)(void*, int), void* ctx) {
    {
      std::lock_guard lock(mutex_);
      fn_ = fn;
      ctx_ = ctx;
      pending_ = static_cast<int>(threads_.size());
      ++generation_;
    }
    start_.notify_all();
    fn(ctx, 0);
    std::unique_lock lock(mutex_);
    done_.wait(lock, [this] { return pending_ == 0; });
  }

  void loop(int index) {
    std::uint64_t seen = 0;
    while (true) {
      void (*fn)(void*, int) = nullptr;
      void* ctx = nullptr;
      {
        std::unique_lock lock(mutex_);
        start_.wait(lock, [&] { return stop_ || generation_ != seen; });
        if (stop_) return;
        seen = generation_;
        fn = fn_;
        ctx = ctx_;
      }
      fn(ctx, index);
      {
        std::lock_guard lock(mutex_);
        --pending_;
      }
      done_.notify_one();
    }
  }

  std::vector<std::thread> threads_;
  std::mutex mutex_;
  std::condition_variable start_, done_;
  void (*fn_)(void*, int) = nullptr;
  void* ctx_ = nullptr;
  std::uint64_t generation_ = 0;
  int pending_ = 0;
  bool stop_ = false;
};

}  // namespace rsrio::sim::detail
