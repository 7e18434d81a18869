// StopWatch (framework/src/stop_watch.hpp): a stop request reaches a thread that waits, at once,
// whether it comes from requestStop() or from the signal handler itself (through its pipe).
#include "stop_watch.hpp"

#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <future>
#include <thread>

#include "terramrf/stop_request.hpp"

namespace terramrf {
namespace {
struct StopRequestGuard {
  StopRequestGuard() { clearStopRequest(); }
  ~StopRequestGuard() { clearStopRequest(); }
};
constexpr auto kPatience = std::chrono::seconds(20);  // "at once", with room for a loaded machine
}  // namespace

TEST(StopWatch, ARequestFromAnotherThreadRunsItsFunctionOnce) {
  StopRequestGuard guard;
  std::promise<std::thread::id> fired;
  int calls = 0;
  {
    StopWatch watch([&] {
      ++calls;
      fired.set_value(std::this_thread::get_id());
    });
    std::thread([] { requestStop(SIGTERM); }).join();
    auto f = fired.get_future();
    ASSERT_EQ(f.wait_for(kPatience), std::future_status::ready);
    EXPECT_NE(f.get(), std::this_thread::get_id());
  }
  EXPECT_EQ(calls, 1);
}

TEST(StopWatch, ARequestMadeBeforeTheWatchRunsItAtOnceAndNoneNever) {
  StopRequestGuard guard;
  bool called = false;
  {
    StopWatch watch([&] { called = true; });  // ends without waiting for anything
  }
  EXPECT_FALSE(called);
  requestStop(SIGINT);
  std::promise<void> fired;
  StopWatch watch([&] { fired.set_value(); });
  EXPECT_EQ(fired.get_future().wait_for(kPatience), std::future_status::ready);
}

// The handler can only write to a pipe; the watch sees it. A cleared request leaves nothing
// behind for the next watch.
TEST(StopWatch, TheSignalHandlerWakesTheWatch) {
  StopRequestGuard guard;
  struct sigaction saved_int {
  }, saved_term{}, dfl{};
  sigaction(SIGINT, nullptr, &saved_int);
  sigaction(SIGTERM, nullptr, &saved_term);
  dfl.sa_handler = SIG_DFL;
  sigemptyset(&dfl.sa_mask);
  sigaction(SIGINT, &dfl, nullptr);
  installStopHandlers();
  std::promise<void> fired;
  {
    StopWatch watch([&] { fired.set_value(); });
    ASSERT_EQ(::raise(SIGINT), 0);
    EXPECT_EQ(fired.get_future().wait_for(kPatience), std::future_status::ready);
  }
  sigaction(SIGINT, &saved_int, nullptr);
  sigaction(SIGTERM, &saved_term, nullptr);
  clearStopRequest();
  bool called = false;
  {
    StopWatch watch([&] { called = true; });
  }
  EXPECT_FALSE(called);
}

}  // namespace terramrf
