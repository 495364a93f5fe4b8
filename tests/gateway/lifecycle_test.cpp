// The ordered component list (gateway/lifecycle.h): configure and start in list order, stop and
// release in reverse, and a failure in configure or start undoes exactly what was done before it.
#include "gateway/lifecycle.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

namespace doppel::gateway {
namespace {

// Four components that write what they do into `log` ("a.configure", ...); `failing` (as
// "b.start") throws instead.
struct Recorded {
  std::vector<std::string> log;
  std::string failing;

  Component component(const std::string& name) {
    const auto step = [this, name](const char* what) {
      return [this, name, what] {
        const std::string event = name + "." + what;
        if (event == failing) throw std::runtime_error(event + " failed");
        log.push_back(event);
      };
    };
    return {name, step("configure"), step("start"), step("stop"), step("release")};
  }
  void fill(Lifecycle& lifecycle) {
    for (const char* name : {"a", "b", "c", "d"}) lifecycle.add(component(name));
  }
};

using Log = std::vector<std::string>;

TEST(Lifecycle, ConfiguresAndStartsInListOrderAndStopsAndReleasesInReverse) {
  Recorded recorded;
  {
    Lifecycle sut;
    recorded.fill(sut);
    EXPECT_EQ(sut.names(), (std::vector<std::string>{"a", "b", "c", "d"}));
    sut.configure();
    sut.start();
    EXPECT_TRUE(sut.started());
    sut.stop();
    sut.stop();  // idempotent
    EXPECT_FALSE(sut.started());
  }  // released by its destructor
  EXPECT_EQ(recorded.log, (Log{"a.configure", "b.configure", "c.configure", "d.configure", "a.start", "b.start", "c.start",
                               "d.start", "d.stop", "c.stop", "b.stop", "a.stop", "d.release", "c.release", "b.release",
                               "a.release"}));
}

TEST(Lifecycle, AFailedStartStopsItAndWhatStartedBeforeInReverseAndRethrows) {
  Recorded recorded;
  recorded.failing = "c.start";
  Lifecycle sut;
  recorded.fill(sut);
  sut.configure();
  try {
    sut.start();
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "c.start failed");
  }
  EXPECT_FALSE(sut.started());
  sut.release();
  EXPECT_EQ(recorded.log, (Log{"a.configure", "b.configure", "c.configure", "d.configure", "a.start", "b.start", "c.stop",
                               "b.stop", "a.stop", "d.release", "c.release", "b.release", "a.release"}));
}

TEST(Lifecycle, AFailedConfigureReleasesItAndWhatWasConfiguredBeforeInReverseAndRethrows) {
  Recorded recorded;
  recorded.failing = "c.configure";
  Lifecycle sut;
  recorded.fill(sut);
  EXPECT_THROW(sut.configure(), std::runtime_error);
  sut.start();  // nothing is configured: nothing starts
  EXPECT_FALSE(sut.started());
  EXPECT_EQ(recorded.log, (Log{"a.configure", "b.configure", "c.release", "b.release", "a.release"}));
}

TEST(Lifecycle, AFailingStopIsReportedAndTheOthersStillStop) {
  Recorded recorded;
  recorded.failing = "c.stop";
  Lifecycle sut;
  recorded.fill(sut);
  sut.configure();
  sut.start();
  testing::internal::CaptureStderr();
  sut.stop();
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_NE(err.find("stop c: c.stop failed"), std::string::npos) << err;
  EXPECT_EQ(Log(recorded.log.end() - 3, recorded.log.end()), (Log{"d.stop", "b.stop", "a.stop"}));
}

TEST(Lifecycle, TheHookSeesEveryTransitionAndFailsTheOneItThrowsFrom) {
  Recorded recorded;
  std::vector<std::string> seen;
  Lifecycle sut([&seen](std::string_view component, Transition transition) {
    seen.push_back(std::string(component) + "." + std::string(transition_name(transition)));
    if (component == "b" && transition == Transition::kStart) throw std::runtime_error("injected");
  });
  recorded.fill(sut);
  sut.configure();
  EXPECT_THROW(sut.start(), std::runtime_error);
  EXPECT_EQ(Log(recorded.log.begin() + 4, recorded.log.end()), (Log{"a.start", "b.stop", "a.stop"}));  // b's start never ran
  EXPECT_EQ(Log(seen.begin() + 4, seen.end()), (Log{"a.start", "b.start", "b.stop", "a.stop"}));
}

}  // namespace
}  // namespace doppel::gateway
