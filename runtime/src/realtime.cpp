#include "rsrio/runtime/realtime.hpp"

#include <cerrno>
#include <cstring>
#include <system_error>

#include <sched.h>
#include <sys/resource.h>
#include <unistd.h>
#include <sys/mman.h>

namespace rsrio {

RtThread::~RtThread() { join(); }

void* RtThread::trampoline(void* self) {
  auto* t = static_cast<RtThread*>(self);
  // Linux: nice is per thread. Lowering one's own priority needs no privilege; if it fails the
  // thread merely runs at the default priority.
  if (t->nice_ != 0) (void)::setpriority(PRIO_PROCESS, static_cast<id_t>(::gettid()), t->nice_);
  t->body_();
  return nullptr;
}

ThreadPlacement RtThread::start(const ThreadOptions& o, std::function<void()> body) {
  body_ = std::move(body);
  nice_ = o.fifo_priority > 0 ? 0 : o.nice;
  pthread_attr_t attr;
  pthread_attr_init(&attr);
  pthread_attr_setstacksize(&attr, std::max<std::size_t>(o.stack_bytes, PTHREAD_STACK_MIN));
  ThreadPlacement placement;
  if (o.fifo_priority > 0) {
    // Ask for SCHED_FIFO at creation (explicit, not inherited), so the body never runs at the
    // wrong priority. EPERM comes back as the return value of pthread_create.
    sched_param sp{};
    sp.sched_priority = o.fifo_priority;
    pthread_attr_setinheritsched(&attr, PTHREAD_EXPLICIT_SCHED);
    pthread_attr_setschedpolicy(&attr, SCHED_FIFO);
    pthread_attr_setschedparam(&attr, &sp);
    int rc = pthread_create(&handle_, &attr, &RtThread::trampoline, this);
    if (rc == 0) {
      placement.realtime = true;
    } else if (rc == EPERM) {
      placement.note = "SCHED_FIFO " + std::to_string(o.fifo_priority) + " for '" + o.name +
                       "' not permitted (RLIMIT_RTPRIO / CAP_SYS_NICE; systemd: LimitRTPRIO=); running SCHED_OTHER";
      pthread_attr_setinheritsched(&attr, PTHREAD_INHERIT_SCHED);
      rc = pthread_create(&handle_, &attr, &RtThread::trampoline, this);
    }
    if (rc != 0) {
      pthread_attr_destroy(&attr);
      throw std::system_error(rc, std::generic_category(), "pthread_create " + o.name);
    }
  } else {
    const int rc = pthread_create(&handle_, &attr, &RtThread::trampoline, this);
    if (rc != 0) {
      pthread_attr_destroy(&attr);
      throw std::system_error(rc, std::generic_category(), "pthread_create " + o.name);
    }
  }
  pthread_attr_destroy(&attr);
  started_ = true;
  if (!o.name.empty()) pthread_setname_np(handle_, o.name.substr(0, 15).c_str());
  if (!o.cpus.empty()) {
    cpu_set_t set;
    CPU_ZERO(&set);
    for (int c : o.cpus) CPU_SET(c, &set);
    const int rc = pthread_setaffinity_np(handle_, sizeof set, &set);
    placement.pinned = rc == 0;
    if (rc != 0) placement.note += (placement.note.empty() ? "" : "; ") + std::string("CPU affinity: ") + std::strerror(rc);
  }
  return placement;
}

void RtThread::join() {
  if (started_) {
    pthread_join(handle_, nullptr);
    started_ = false;
  }
}

bool lock_memory(std::string& error) {
  if (::mlockall(MCL_CURRENT | MCL_FUTURE) == 0) return true;
  error = std::string("mlockall: ") + std::strerror(errno) +
          " (RLIMIT_MEMLOCK too small? systemd: LimitMEMLOCK=infinity)";
  return false;
}

}  // namespace rsrio
