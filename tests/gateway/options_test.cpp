#include "gateway/options.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <stdexcept>
#include <vector>

namespace doppel::gateway {
namespace {

Options parse(std::vector<const char*> args) {
  args.insert(args.begin(), "doppel");
  return parse_options(static_cast<int>(args.size()), args.data());
}

TEST(Options, NoArgumentsRunTheDefaultRobotWithWireTiming) {
  Options sut = parse({});
  ASSERT_EQ(sut.buses.robots.size(), 1u);
  EXPECT_EQ(sut.buses.robots[0], "fumanoid-2011");
  EXPECT_EQ(sut.buses.link_dir, bus::default_link_dir());
  EXPECT_FALSE(sut.buses.allow_shared_link_dir);
  EXPECT_EQ(sut.buses.timing, bus::TimingMode::kWire);
  EXPECT_EQ(sut.buses.latency_timer_ms, 0u);
  EXPECT_DOUBLE_EQ(sut.buses.processing_us, 50.0);
}

TEST(Options, EveryOptionIsParsed) {
  Options sut = parse({"--robot", "mx-test", "--robot", "/x/r.textproto", "--link-dir", "/tmp/l", "--timing", "fast",
                       "--processing-us", "20", "--latency-timer", "16", "--robots-dir", "/r", "--rt-priority", "50",
                       "--allow-shared-link-dir", "--verbose"});
  EXPECT_EQ(sut.buses.robots, (std::vector<std::string>{"mx-test", "/x/r.textproto"}));
  EXPECT_EQ(sut.buses.link_dir, "/tmp/l");
  EXPECT_EQ(sut.buses.timing, bus::TimingMode::kFast);
  EXPECT_DOUBLE_EQ(sut.buses.processing_us, 20.0);
  EXPECT_EQ(sut.buses.latency_timer_ms, 16u);
  EXPECT_EQ(sut.buses.robots_dir, "/r");
  EXPECT_EQ(sut.buses.rt_priority, 50);
  EXPECT_TRUE(sut.buses.allow_shared_link_dir);
  EXPECT_TRUE(sut.cameras.verbose);
}

TEST(Options, BadOptionsAreRejectedWithTheirName) {
  EXPECT_THROW(parse({"--timing", "slow"}), std::invalid_argument);
  EXPECT_THROW(parse({"--latency-timer", "256"}), std::invalid_argument);
  EXPECT_THROW(parse({"--latency-timer", "1x"}), std::invalid_argument);
  EXPECT_THROW(parse({"--robot"}), std::invalid_argument);
  EXPECT_THROW(parse({"--rt-priority", "100"}), std::invalid_argument);
  EXPECT_THROW(parse({"--link-dir", ""}), std::invalid_argument);
  try {
    parse({"--bogus"});
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("--bogus"), std::string::npos);
  }
  for (auto [option, value] : {std::pair{"--timing", "slow"}, std::pair{"--latency-timer", "1x"},
                               std::pair{"--processing-us", "-1"}, std::pair{"--rt-priority", "100"}}) {
    try {
      parse({option, value});
      FAIL() << option << " " << value << ": no exception";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(option), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(value), std::string::npos) << e.what();
    }
  }
}

TEST(Options, TheViewerOptions) {
  const Options defaults = parse({});
  EXPECT_TRUE(defaults.viewer.enabled);
  EXPECT_EQ(defaults.viewer.dir, "");
  const Options sut = parse({"--viewer", "0", "--viewer-dir", "/srv/viewer"});
  EXPECT_EQ(sut.viewer.port, 0);
  EXPECT_EQ(sut.viewer.dir, "/srv/viewer");
  EXPECT_FALSE(parse({"--no-viewer"}).viewer.enabled);
  try {
    parse({"--viewer-dir", ""});
    FAIL() << "an empty --viewer-dir was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("--viewer-dir"), std::string::npos) << e.what();
  }
}

TEST(Options, ARepeatedOptionKeepsItsLastValue) {
  Options sut = parse({"--timing", "fast", "--timing", "wire", "--latency-timer", "4", "--latency-timer", "8"});

  EXPECT_EQ(sut.buses.timing, bus::TimingMode::kWire);
  EXPECT_EQ(sut.buses.latency_timer_ms, 8u);
}

TEST(Options, IntegersWithLeadingZerosAreDecimal) {
  Options sut = parse({"--latency-timer", "010", "--processing-us", "007"});

  EXPECT_EQ(sut.buses.latency_timer_ms, 10u);
  EXPECT_DOUBLE_EQ(sut.buses.processing_us, 7.0);
}

TEST(Options, FlagsAreSet) {
  Options sut = parse({"--no-camera", "--no-hold", "--external-roudi", "--list-robots", "--help"});

  EXPECT_FALSE(sut.cameras.enabled);
  EXPECT_FALSE(sut.world.hold);
  EXPECT_TRUE(sut.cameras.external_roudi);
  EXPECT_TRUE(sut.buses.list_robots);
  EXPECT_TRUE(sut.help);
  EXPECT_TRUE(parse({}).cameras.enabled);
  EXPECT_TRUE(parse({}).world.hold);
  EXPECT_TRUE(parse({"-h"}).help);
}

TEST(Options, PhysicsEngineIsChosenOnceOrNone) {
  EXPECT_EQ(parse({}).world.physics, physics::Engine::kOde);
  EXPECT_EQ(parse({"--physics", "bullet"}).world.physics, physics::Engine::kBullet);
  EXPECT_EQ(parse({"--physics", "ode"}).world.physics, physics::Engine::kOde);
  EXPECT_FALSE(parse({"--physics", "none"}).world.physics.has_value());
  try {
    parse({"--physics", "mujoco"});
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("--physics"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("mujoco"), std::string::npos) << e.what();
  }
}

TEST(Options, SessionFileIsTakenAndMustBeNamed) {
  Options sut = parse({"--session", "sessions/sideline-camera.textproto"});

  EXPECT_EQ(sut.world.session, "sessions/sideline-camera.textproto");
  EXPECT_TRUE(parse({}).world.session.empty());
  EXPECT_THROW(parse({"--session"}), std::invalid_argument);
  EXPECT_THROW(parse({"--session", ""}), std::invalid_argument);
}

TEST(Options, SolverIterationsAreANumberFrom1To1000) {
  EXPECT_FALSE(parse({}).world.solver_iterations.has_value());  // the robot files', else physics::WorldOptions' 10
  EXPECT_EQ(parse({"--solver-iterations", "100"}).world.solver_iterations, 100);
  EXPECT_THROW(parse({"--solver-iterations", "0"}), std::invalid_argument);
  EXPECT_THROW(parse({"--solver-iterations", "1001"}), std::invalid_argument);
  EXPECT_THROW(parse({"--solver-iterations", "many"}), std::invalid_argument);
}

TEST(Options, HelpDocumentsEveryOption) {
  std::string text = usage();
  for (const char* option : {"--robot", "--link-dir", "--timing", "--processing-us", "--latency-timer",
                             "--robots-dir", "--rt-priority", "--list-robots", "--help", "ttyDXL0", "robot<r>/ttyDXL<b>",
                             "--session", "--no-camera", "--external-roudi", "--allow-shared-link-dir", "--verbose",
                             "--solver-iterations"}) {
    EXPECT_NE(text.find(option), std::string::npos) << option;
  }
}

TEST(Options, HelpIsGroupedByServiceAndShowsTheDefaults) {
  const std::string text = usage();
  // The defaults the hand-written help gave before it was generated from the declarations.
  for (const char* shown : {"--processing-us US=50", "--latency-timer MS=0", "--timing wire|fast=wire",
                            "--physics ode|bullet|none=ode", "--viewer PORT=7580", "--handshake-port PORT=7590",
                            "--record-compression zstd|lz4|none=zstd", "--world-model-rate HZ=30", "--truth-udp-port BASE=7600",
                            "--gc-teams A,B=1,2", "--gc-players N=4", "--gc-return ADDRESS:PORT=127.0.0.1:3939",
                            "--gc-watch ADDRESS:PORT|off=255.255.255.255:3838", "--lockstep-watchdog S=5"}) {
    EXPECT_NE(text.find(shown), std::string::npos) << shown << "\n" << text;
  }
  std::size_t last = 0;
  for (const char* group : {"\nRobots and their buses:\n", "\nWorld:\n", "\nEEPROM state:\n", "\nCameras:\n",
                            "\nViewer and simulation control:\n", "\nSession handshake:\n", "\nRecording:\n",
                            "\nWorld model and sensor levels:\n", "\nGameController:\n", "\nTeam communication:\n",
                            "\nLockstep:\n"}) {
    const std::size_t at = text.find(group);
    EXPECT_NE(at, std::string::npos) << group;
    EXPECT_GT(at, last) << group << " out of order";
    last = at;
  }
  EXPECT_EQ(text.find("{false}"), std::string::npos) << "a --no- flag shows CLI11's internals";
}

TEST(Options, StateDirectoryDefaultsToXdgStateHomeAndFreshIsAFlag) {
  ::setenv("XDG_STATE_HOME", "/var/tmp/xdg-state", 1);
  EXPECT_EQ(parse({}).state.dir, "/var/tmp/xdg-state/doppel");
  EXPECT_FALSE(parse({}).state.fresh);
  ::unsetenv("XDG_STATE_HOME");
  ::setenv("HOME", "/home/someone", 1);
  EXPECT_EQ(parse({}).state.dir, "/home/someone/.local/state/doppel");
  const Options sut = parse({"--state-dir", "/s", "--fresh"});
  EXPECT_EQ(sut.state.dir, "/s");
  EXPECT_TRUE(sut.state.fresh);
  EXPECT_THROW(parse({"--state-dir", ""}), std::invalid_argument);
  EXPECT_TRUE(Options{}.state.dir.empty());  // a Gateway built in-process keeps no state unless told
  for (const char* option : {"--state-dir", "--fresh"}) {
    EXPECT_NE(usage().find(option), std::string::npos) << option;
  }
}

TEST(Options, GameControllerIsOffAndLoopbackUnlessTheUserSaysOtherwise) {
  const Options defaults = parse({});
  EXPECT_FALSE(defaults.gamecontroller.enabled);
  EXPECT_EQ(defaults.gamecontroller.destination, "127.0.0.1:3838");
  EXPECT_EQ(defaults.gamecontroller.return_to, "127.0.0.1:3939");
  EXPECT_EQ(defaults.gamecontroller.watch, "255.255.255.255:3838");  // receives broadcasts only
  EXPECT_TRUE(defaults.teamcomm.hub.empty());
  const Options sut = parse({"--gamecontroller", "--gc-teams", "5,6", "--gc-players", "3", "--gc-watch", "off",
                             "--teamcomm", "0", "--teamcomm-robot", "7:1:44001", "--teamcomm-robot", "7:2:44002",
                             "--teamcomm-loss", "0.2", "--teamcomm-delay-ms", "20", "--teamcomm-jitter", "normal"});
  EXPECT_TRUE(sut.gamecontroller.enabled);
  EXPECT_TRUE(parse({"--gamecontroller", "on"}).gamecontroller.enabled);
  EXPECT_FALSE(parse({"--gamecontroller", "off"}).gamecontroller.enabled);
  EXPECT_TRUE(parse({"--gamecontroller", "--gc-teams", "3,4"}).gamecontroller.enabled);
  EXPECT_THROW(parse({"--gamecontroller", "maybe"}), std::invalid_argument);
  EXPECT_EQ(sut.gamecontroller.team_a, 5);
  EXPECT_EQ(sut.gamecontroller.team_b, 6);
  EXPECT_EQ(sut.gamecontroller.players, 3);
  EXPECT_EQ(sut.gamecontroller.watch, "off");
  EXPECT_EQ(sut.teamcomm.hub, "0");
  EXPECT_EQ(sut.teamcomm.robots.size(), 2u);
  EXPECT_DOUBLE_EQ(sut.teamcomm.link.loss_probability, 0.2);
  EXPECT_EQ(sut.teamcomm.link.delay_ns, 20'000'000);
  EXPECT_EQ(sut.teamcomm.link.jitter, teamcomm::Jitter::kHalfNormal);
  for (const std::vector<const char*>& bad : std::vector<std::vector<const char*>>{
           {"--gc-teams", "5"}, {"--gc-teams", "5,5"}, {"--gc-teams", "5,256"}, {"--gc-players", "12"},
           {"--teamcomm-loss", "1.5"}, {"--teamcomm-robot", "7:1:44001"}}) {
    EXPECT_THROW(parse(bad), std::invalid_argument) << bad[0] << " " << bad[1];
  }
  try {
    parse({"--teamcomm-robot", "7:1:44001"});
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("needs --teamcomm"), std::string::npos) << e.what();
  }
  for (const char* option : {"--gamecontroller", "--gc-teams", "--gc-destination", "--gc-return", "--gc-watch",
                             "--teamcomm", "--teamcomm-robot", "--teamcomm-loss"}) {
    EXPECT_NE(usage().find(option), std::string::npos) << option;
  }
}

TEST(Options, SensorLevelsRate) {
  EXPECT_EQ(parse({}).truth.sensor_levels_hz, 0.0) << "off unless asked";
  EXPECT_EQ(parse({"--sensor-levels", "100"}).truth.sensor_levels_hz, 100.0);
  EXPECT_THROW(parse({"--sensor-levels", "0"}), std::invalid_argument);
  EXPECT_THROW(parse({"--sensor-levels", "1001"}), std::invalid_argument);
  EXPECT_NE(usage().find("--sensor-levels HZ"), std::string::npos);
}

}  // namespace
}  // namespace doppel::gateway
