// Real-time set-up: SCHED_FIFO where permitted, the explained fallback where not (checked in a
// child process that gives up root), and sd_notify through a real AF_UNIX notification socket.
#include "rsrio/runtime/realtime.hpp"

#include <atomic>
#include <cstdlib>
#include <filesystem>

#include <pwd.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <catch2/catch_test_macros.hpp>

#include "rsrio/runtime/systemd_notify.hpp"

TEST_CASE("a thread asks for SCHED_FIFO and reports what it got", "[realtime][concurrency]") {
  std::atomic<int> policy{-1};
  rsrio::RtThread t;
  const auto placement = t.start({"rsrio-test-rt", 10, {0}, 256 * 1024}, [&] {
    sched_param sp{};
    int p = 0;
    pthread_getschedparam(pthread_self(), &p, &sp);
    policy = p;
  });
  t.join();
  if (placement.realtime) {
    CHECK(policy == SCHED_FIFO);
    CHECK(placement.note.empty());
  } else {
    CHECK(policy == SCHED_OTHER);
    CHECK(placement.note.find("not permitted") != std::string::npos);
  }
  CHECK(placement.pinned);
}

TEST_CASE("without the right to SCHED_FIFO the thread runs SCHED_OTHER, with one explanation", "[realtime]") {
  // In a child: drop RLIMIT_RTPRIO to 0 and become an unprivileged user, then ask again.
  const pid_t pid = fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {
    rlimit zero{0, 0};
    setrlimit(RLIMIT_RTPRIO, &zero);
    if (getuid() == 0) {
      const passwd* nobody = getpwnam("nobody");
      if (!nobody || setgid(nobody->pw_gid) != 0 || setuid(nobody->pw_uid) != 0) _exit(3);
    }
    int policy = -1;
    rsrio::RtThread t;
    const auto placement = t.start({"rsrio-test-nort", 50, {}, 256 * 1024}, [&] {
      sched_param sp{};
      pthread_getschedparam(pthread_self(), &policy, &sp);
    });
    t.join();
    const bool ok = !placement.realtime && policy == SCHED_OTHER && placement.note.find("LimitRTPRIO") != std::string::npos;
    _exit(ok ? 0 : 1);
  }
  int status = 0;
  waitpid(pid, &status, 0);
  REQUIRE(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 0);
}

TEST_CASE("sd_notify reaches a notification socket; without one it is a no-op", "[realtime]") {
  unsetenv("NOTIFY_SOCKET");
  CHECK_FALSE(rsrio::systemd::ready());
  const std::string path = (std::filesystem::temp_directory_path() / ("rsrio_notify_" + std::to_string(getpid()))).string();
  const int fd = socket(AF_UNIX, SOCK_DGRAM, 0);
  REQUIRE(fd >= 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", path.c_str());
  REQUIRE(bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0);
  setenv("NOTIFY_SOCKET", path.c_str(), 1);
  CHECK(rsrio::systemd::ready());
  char buf[64] = {};
  const ssize_t n = recv(fd, buf, sizeof buf - 1, 0);
  CHECK(std::string(buf, n > 0 ? static_cast<std::size_t>(n) : 0) == "READY=1");
  setenv("WATCHDOG_USEC", "2000000", 1);
  setenv("WATCHDOG_PID", std::to_string(getpid()).c_str(), 1);
  CHECK(rsrio::systemd::watchdog_interval() == std::chrono::seconds(2));
  unsetenv("NOTIFY_SOCKET");
  unsetenv("WATCHDOG_USEC");
  unsetenv("WATCHDOG_PID");
  close(fd);
  std::filesystem::remove(path);
}
