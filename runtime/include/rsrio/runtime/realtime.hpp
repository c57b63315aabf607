// Real-time thread set-up: SCHED_FIFO where the process may (RLIMIT_RTPRIO or CAP_SYS_NICE), a
// single explained fallback to SCHED_OTHER where it may not, CPU affinity, explicit small stacks,
// and mlockall once the threads exist (an 8 MiB default stack per thread does not fit systemd's
// default 8 MiB RLIMIT_MEMLOCK; reference/runtime.md Sec. 4.1).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <pthread.h>

namespace rsrio {

struct ThreadOptions {
  std::string name;              // shown by top -H / ps -L (15 characters kept)
  int fifo_priority = 0;         // 1..99: SCHED_FIFO; 0: SCHED_OTHER
  std::vector<int> cpus;         // empty: any CPU
  std::size_t stack_bytes = 512 * 1024;
  int nice = 0;                  // SCHED_OTHER threads: their nice value (0..19: lower priority)
};

/// What the thread actually got. `note` says why it is not what was asked (once, for the log).
struct ThreadPlacement {
  bool realtime = false;
  bool pinned = false;
  std::string note;
};

/// A joinable thread created with explicit attributes. The body runs after the scheduling
/// attempt; the result of that attempt is available once start() returns.
class RtThread {
 public:
  RtThread() = default;
  ~RtThread();  // joins
  RtThread(const RtThread&) = delete;
  RtThread& operator=(const RtThread&) = delete;

  /// Throws std::system_error when the thread cannot be created at all.
  ThreadPlacement start(const ThreadOptions& options, std::function<void()> body);
  void join();
  bool joinable() const { return started_; }

 private:
  static void* trampoline(void* self);
  pthread_t handle_{};
  bool started_ = false;
  std::function<void()> body_;
  int nice_ = 0;
};

/// mlockall(MCL_CURRENT | MCL_FUTURE). False with `error` filled when the limit forbids it.
bool lock_memory(std::string& error);

}  // namespace rsrio
