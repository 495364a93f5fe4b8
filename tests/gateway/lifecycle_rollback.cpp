// doppel's components (Gateway::components(): buses, world, cameras, control API, recorder,
// truth, handshake, GameController and team hub, lockstep clock, ...) start from one ordered list:
// a failure injected in the configure or the start of each one undoes it and what was done before
// it, in reverse order, and leaves no link, socket or shared-memory file behind. Cameras and the world
// model run over an in-process RouDi: its own executable, holding the `roudi` lock.

#include <gtest/gtest.h>
#include <stdlib.h>
#include <sys/stat.h>

#include <algorithm>
#include <filesystem>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "gateway/gateway.h"

namespace doppel::testing {
namespace {

namespace fs = std::filesystem;
using gateway::Transition;
using Log = std::vector<std::string>;

// The entries of `dir` (recursively); none when it does not exist.
std::set<std::string> entries(const std::string& dir) {
  std::set<std::string> out;
  std::error_code error;
  if (!fs::exists(dir, error)) return out;
  for (auto it = fs::recursive_directory_iterator(dir, error); !error && it != fs::recursive_directory_iterator(); it.increment(error)) {
    out.insert(it->path().string());
  }
  return out;
}

// The Unix sockets directly in `dir` (iceoryx's runtime and RouDi sockets live in /tmp).
std::set<std::string> sockets(const std::string& dir) {
  std::set<std::string> out;
  std::error_code error;
  for (auto it = fs::directory_iterator(dir, error); !error && it != fs::directory_iterator(); it.increment(error)) {
    struct stat status {};
    if (::lstat(it->path().c_str(), &status) == 0 && S_ISSOCK(status.st_mode)) out.insert(it->path().string());
  }
  return out;
}

class GatewayLifecycle : public ::testing::Test {
 protected:
  void SetUp() override {
    char pattern[] = "/tmp/doppel-lifecycle-XXXXXX";
    ASSERT_NE(::mkdtemp(pattern), nullptr);
    dir_ = pattern;
    // Every component with work to do: two robots (robot1/ links), their cameras, the world model
    // and sensor levels, the recorder, the EEPROM state, the control API, the handshake on its
    // socket and a TCP port, the GameController and the team hub (loopback only).
    options_.buses.link_dir = dir_ + "/links";
    options_.buses.robots = {"fumanoid-2011", "fumanoid-2011"};
    options_.buses.robots_dir = DOPPEL_ROBOTS_DIR;
    options_.buses.timing = bus::TimingMode::kFast;
    options_.cameras.enabled = true;
    options_.truth.world_model = true;
    options_.truth.sensor_levels_hz = 10.0;
    options_.record.path = dir_ + "/run.mcap";
    options_.record.progress = false;
    options_.state.dir = dir_ + "/state";
    options_.viewer.enabled = true;
    options_.viewer.port = 0;
    options_.handshake.enabled = true;
    options_.handshake.port = 0;
    options_.gamecontroller.enabled = true;
    options_.gamecontroller.return_to = "127.0.0.1:0";
    options_.gamecontroller.watch = "off";
    options_.teamcomm.hub = "127.0.0.1:0";
    configs_ = gateway::load_robots(options_);
  }
  void TearDown() override {
    std::error_code ignored;
    fs::remove_all(dir_, ignored);
  }

  // A gateway whose hook writes every transition into log_ ("cameras.start") and throws from `failing`.
  std::unique_ptr<gateway::Gateway> make(const std::string& failing = "") {
    return std::make_unique<gateway::Gateway>(options_, configs_, gateway::SessionConfig{},
                                              [this, failing](std::string_view component, Transition transition) {
                                                const std::string event = std::string(component) + "." +
                                                                          std::string(gateway::transition_name(transition));
                                                log_.push_back(event);
                                                if (event == failing) throw std::runtime_error("injected: " + event);
                                              });
  }

  // The events of `transition` in log_, by component.
  Log of(Transition transition) const {
    const std::string suffix = "." + std::string(gateway::transition_name(transition));
    Log out;
    for (const std::string& event : log_) {
      if (event.size() > suffix.size() && event.compare(event.size() - suffix.size(), suffix.size(), suffix) == 0) {
        out.push_back(event.substr(0, event.size() - suffix.size()));
      }
    }
    return out;
  }

  // Fails each component in its configure, then in its start, and checks what is left.
  void fail_each_component();

  std::string dir_;
  gateway::Options options_;
  std::vector<gateway::RobotConfig> configs_;
  Log log_;
};

TEST_F(GatewayLifecycle, StartsInListOrderAndStopsInReverse) {
  auto sut = make();
  const Log components = sut->components();
  const auto at = [&components](const std::string& name) {
    const auto found = std::find(components.begin(), components.end(), name);
    EXPECT_NE(found, components.end()) << name;
    return found - components.begin();
  };
  // What the order must say (gateway.cpp): links appear last, the handshake comes after what it
  // serves, the recorder and the cameras outlive the threads that feed them.
  EXPECT_LT(at("links"), at("robots"));
  EXPECT_LT(at("world"), at("robots"));
  EXPECT_LT(at("recorder"), at("simulation"));
  EXPECT_LT(at("recorder"), at("buses"));
  EXPECT_LT(at("truth"), at("simulation"));
  EXPECT_LT(at("cameras"), at("simulation"));
  EXPECT_LT(at("cameras"), at("truth"));  // the cameras host iceoryx; truth only when none does
  EXPECT_LT(at("simulation"), at("robots added at run time"));
  EXPECT_LT(at("simulation"), at("control API"));
  EXPECT_LT(at("state"), at("buses"));
  EXPECT_EQ(at("handshake"), static_cast<long>(components.size()) - 1);
  for (const char* name : {"latency timer files", "lockstep clock", "simulation control", "faults", "field services"}) at(name);
  EXPECT_EQ(of(Transition::kConfigure), components);
  sut->start();
  EXPECT_EQ(of(Transition::kStart), components);
  EXPECT_TRUE(fs::is_symlink(options_.buses.link_dir + "/ttyDXL0"));
  EXPECT_TRUE(fs::is_symlink(options_.buses.link_dir + "/robot1/ttyDXL0"));
  EXPECT_TRUE(fs::exists(options_.buses.link_dir + "/handshake.sock"));
  EXPECT_NE(sut->control_port(), 0);
  sut->stop();
  EXPECT_EQ(of(Transition::kStop), Log(components.rbegin(), components.rend()));
  sut.reset();
  EXPECT_EQ(of(Transition::kRelease), Log(components.rbegin(), components.rend()));
  EXPECT_TRUE(entries(options_.buses.link_dir).empty());
}

TEST_F(GatewayLifecycle, AFailureInAnyComponentUndoesWhatCameBeforeItAndLeavesNothingBehind) { fail_each_component(); }

// The same on the lockstep clock (docs/lockstep.md): its clock file lives in the link directory,
// the simulation thread serves the buses.
TEST_F(GatewayLifecycle, UnderLockstepToo) {
  options_.lockstep.enabled = true;
  options_.lockstep.hashes_file = dir_ + "/hashes";
  fail_each_component();
}

void GatewayLifecycle::fail_each_component() {
  const Log components = make()->components();
  log_.clear();
  const std::set<std::string> shm_before = entries("/dev/shm");
  const std::set<std::string> sockets_before = sockets("/tmp");
  for (std::size_t failing = 0; failing < components.size(); ++failing) {
    const Log through(components.begin(), components.begin() + static_cast<long>(failing) + 1);
    const Log reversed(through.rbegin(), through.rend());  // the failing one is undone too
    for (const Transition transition : {Transition::kConfigure, Transition::kStart}) {
      const std::string event = components[failing] + "." + std::string(gateway::transition_name(transition));
      SCOPED_TRACE(event);
      log_.clear();
      try {
        auto sut = make(event);
        sut->start();
        ADD_FAILURE() << "no exception";
      } catch (const std::runtime_error& e) {
        EXPECT_EQ(std::string(e.what()), "injected: " + event);
      }
      if (transition == Transition::kConfigure) {
        EXPECT_EQ(of(Transition::kConfigure), through);
        EXPECT_TRUE(of(Transition::kStart).empty());
        EXPECT_EQ(of(Transition::kRelease), reversed);
      } else {
        EXPECT_EQ(of(Transition::kConfigure), components);
        EXPECT_EQ(of(Transition::kStart), through);
        EXPECT_EQ(of(Transition::kStop), reversed);
        EXPECT_EQ(of(Transition::kRelease), Log(components.rbegin(), components.rend()));
      }
      EXPECT_EQ(entries(options_.buses.link_dir), std::set<std::string>{}) << "links, sockets, token files";
      EXPECT_EQ(entries("/dev/shm"), shm_before) << "iceoryx's shared memory";
      EXPECT_EQ(sockets("/tmp"), sockets_before) << "iceoryx's sockets";
    }
  }
}

}  // namespace
}  // namespace doppel::testing
