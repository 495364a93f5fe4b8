// The GameController: its game's state machine and clocks, and over loopback UDP (ports the system
// picks) the packets a listening robot receives and the return packets it sends back.

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

#include "gamecontroller/game_controller.h"

namespace gc = doppel::gamecontroller;
using namespace std::chrono_literals;

namespace {

constexpr std::uint32_t kLoopback = 0x7f000001;

gc::GameControllerOptions options_for(std::uint16_t port) {
  gc::GameControllerOptions options;
  options.team_a = 12;
  options.team_b = 34;
  options.port = port;
  options.return_port = 0;
  return options;
}

// Waits up to 2 s for `done`.
template <typename F>
bool eventually(F done) {
  const auto deadline = std::chrono::steady_clock::now() + 2s;
  while (std::chrono::steady_clock::now() < deadline) {
    if (done()) {
      return true;
    }
    std::this_thread::sleep_for(5ms);
  }
  return done();
}

}  // namespace

TEST(Game, FollowsInitialReadySetPlayingFinished) {
  gc::Game game(options_for(gc::kDataPort));
  EXPECT_EQ(game.data().state, gc::State::kInitial);
  EXPECT_EQ(game.data().kick_off_team, 12);
  EXPECT_NE(game.set(), "");
  EXPECT_NE(game.play(), "");
  EXPECT_NE(game.finish(), "");
  EXPECT_EQ(game.ready(), "");
  EXPECT_EQ(game.data().state, gc::State::kReady);
  EXPECT_NE(game.play(), "");
  EXPECT_EQ(game.set(), "");
  EXPECT_NE(game.goal(0), "");  // no goal outside PLAYING
  EXPECT_EQ(game.play(), "");
  EXPECT_EQ(game.data().state, gc::State::kPlaying);
  EXPECT_EQ(game.goal(1), "");
  EXPECT_EQ(game.data().teams[1].score, 1);
  EXPECT_EQ(game.data().teams[0].score, 0);
  EXPECT_EQ(game.data().kick_off_team, 12);  // the team that conceded kicks off
  EXPECT_EQ(game.data().state, gc::State::kReady);
  EXPECT_EQ(game.finish(), "");
  EXPECT_EQ(game.data().state, gc::State::kFinished);
  EXPECT_EQ(game.ready(), "");  // the second half
  EXPECT_EQ(game.data().first_half, 0);
  EXPECT_EQ(game.data().kick_off_team, 34);
  EXPECT_EQ(game.finish(), "");
  EXPECT_NE(game.ready(), "");  // after the second half the game is over
  EXPECT_NE(game.goal(2), "");
}

TEST(Game, PenaltyCountsDownAndStaysUntilUnpenalised) {
  gc::Game game(options_for(gc::kDataPort));
  EXPECT_NE(game.penalise(0, 0, 30), "");
  EXPECT_NE(game.penalise(0, 12, 30), "");
  EXPECT_NE(game.penalise(2, 1, 30), "");
  EXPECT_NE(game.penalise(0, 1, 256), "");
  EXPECT_NE(game.unpenalise(1, 2), "");  // not penalised
  ASSERT_EQ(game.penalise(1, 2, 30), "");
  const gc::RobotInfo& robot = game.data().teams[1].players[1];
  EXPECT_EQ(robot.penalty, gc::kPenaltyPickupOrIncapable);
  EXPECT_EQ(robot.secs_till_unpenalised, 30);
  game.advance(10s);  // INITIAL: the clock stands
  EXPECT_EQ(robot.secs_till_unpenalised, 30);
  ASSERT_EQ(game.ready(), "");
  ASSERT_EQ(game.set(), "");
  ASSERT_EQ(game.play(), "");
  game.advance(10500ms);
  EXPECT_EQ(robot.secs_till_unpenalised, 20);  // 19.5 s left shows as 20
  EXPECT_EQ(game.data().secs_remaining, 600 - 10);
  game.advance(25s);
  EXPECT_EQ(robot.secs_till_unpenalised, 0);
  EXPECT_EQ(robot.penalty, gc::kPenaltyPickupOrIncapable);
  EXPECT_EQ(game.unpenalise(1, 2), "");
  EXPECT_EQ(robot.penalty, gc::kPenaltyNone);
}

TEST(GameController, RefusesAddressesThatAreNotIPv4) {
  gc::GameControllerOptions options = options_for(gc::kDataPort);
  options.address = "robot.local";
  std::string error;
  EXPECT_EQ(gc::GameController::create(options, error), nullptr);
  EXPECT_NE(error.find("robot.local"), std::string::npos) << error;
}

TEST(GameController, AStateChangeReachesAListeningRobotAsTheHeadersBytes) {
  std::string error;
  std::optional<gc::UdpSocket> robot = gc::UdpSocket::open(kLoopback, 0, false, error);
  ASSERT_TRUE(robot) << error;
  std::unique_ptr<gc::GameController> controller = gc::GameController::create(options_for(robot->local_port()), error);
  ASSERT_NE(controller, nullptr) << error;
  EXPECT_EQ(controller->destination().address, kLoopback);
  controller->start();

  std::vector<std::uint8_t> buffer(2048);
  gc::Endpoint from;
  std::optional<std::size_t> length = robot->receive(buffer, 2000ms, &from);
  ASSERT_TRUE(length);
  EXPECT_EQ(from.address, kLoopback);
  ASSERT_EQ(*length, 688u);
  EXPECT_EQ(buffer[9], 0);  // state: STATE_INITIAL

  controller->with_game([](gc::Game& game) {
    EXPECT_EQ(game.ready(), "");
    EXPECT_EQ(game.penalise(0, 3, 30), "");
    return 0;
  });
  // Offsets from include/RoboCupGameControlData.h (see packet_test.cpp for the whole layout).
  const auto ready_arrived = [&] {
    for (;;) {
      length = robot->receive(buffer, 2000ms);
      if (!length || *length != 688) {
        return false;
      }
      if (buffer[9] == 1) {
        return true;
      }
    }
  };
  ASSERT_TRUE(ready_arrived());
  EXPECT_EQ(std::string(buffer.begin(), buffer.begin() + 4), "RGme");
  EXPECT_EQ(buffer[4] | (buffer[5] << 8), 12);           // version
  EXPECT_EQ(buffer[7], 4);                               // playersPerTeam
  EXPECT_EQ(buffer[10], 1);                              // firstHalf
  EXPECT_EQ(buffer[11], 12);                             // kickOffTeam
  EXPECT_EQ(buffer[20] | (buffer[21] << 8), 600);        // secsRemaining
  EXPECT_EQ(buffer[24], 12);                             // teams[0].teamNumber
  EXPECT_EQ(buffer[25], 0);                              // teams[0].teamColour (cyan)
  EXPECT_EQ(buffer[24 + 266 + 6 * 2], 34);               // teams[0].players[2].penalty (HL_PICKUP_OR_INCAPABLE)
  // .secsTillUnpenalised: 30 s, counting down in READY since penalise(), shown rounded up.
  EXPECT_GE(buffer[24 + 266 + 6 * 2 + 1], 28);
  EXPECT_LE(buffer[24 + 266 + 6 * 2 + 1], 30);
  EXPECT_EQ(buffer[24 + 332], 34);                       // teams[1].teamNumber
  EXPECT_EQ(buffer[24 + 332 + 1], 1);                    // teams[1].teamColour (magenta)

  // Every packet decodes and equals what the controller holds, packet number aside.
  gc::GameControlData decoded;
  ASSERT_EQ(gc::decode(std::span(buffer).first(688), decoded), gc::DecodeStatus::kOk);
  EXPECT_EQ(decoded.state, gc::State::kReady);
  controller->stop();
  EXPECT_GE(controller->counters().sent, 2u);
  EXPECT_EQ(controller->counters().send_errors, 0u);
}

TEST(GameController, SendsTwiceASecond) {
  // The Humanoid League's GameController sends every 500 ms.
  EXPECT_EQ(gc::GameControllerOptions{}.period, 500ms);
  std::string error;
  std::optional<gc::UdpSocket> robot = gc::UdpSocket::open(kLoopback, 0, false, error);
  ASSERT_TRUE(robot) << error;
  std::unique_ptr<gc::GameController> controller = gc::GameController::create(options_for(robot->local_port()), error);
  ASSERT_NE(controller, nullptr) << error;
  // Packet k leaves at the sender's start + k periods (absolute deadlines), never earlier: a lower
  // bound that holds on a loaded machine (later is the machine's business, not asserted).
  const auto before_start = std::chrono::steady_clock::now();
  controller->start();
  std::vector<std::uint8_t> buffer(2048);
  std::uint8_t first_number = 0;
  for (int k = 0; k < 4; ++k) {
    ASSERT_TRUE(robot->receive(buffer, 10s)) << "packet " << k;
    const auto since_start = std::chrono::steady_clock::now() - before_start;
    EXPECT_GE(since_start, k * 500ms) << "packet " << k;
    if (k == 0) first_number = buffer[6];
  }
  controller->stop();
  EXPECT_EQ(buffer[6], static_cast<std::uint8_t>(first_number + 3));  // packetNumber counts every packet
}

TEST(GameController, KeepsTheLastReturnPerRobotAndCountsGarbage) {
  std::string error;
  std::optional<gc::UdpSocket> robot = gc::UdpSocket::open(kLoopback, 0, false, error);
  ASSERT_TRUE(robot) << error;
  std::unique_ptr<gc::GameController> controller = gc::GameController::create(options_for(robot->local_port()), error);
  ASSERT_NE(controller, nullptr) << error;
  ASSERT_NE(controller->return_port(), 0);
  controller->start();
  const gc::Endpoint to{kLoopback, controller->return_port()};

  const auto send = [&](std::vector<std::uint8_t> bytes) { ASSERT_TRUE(robot->send_to(to, bytes, error)) << error; };
  send({'R', 'G', 'r', 't', 2, 12, 3, 2});  // team 12 player 3: alive
  send({'R', 'G', 'r', 't', 2, 34, 1, 0});  // team 34 player 1: manual penalise
  send({'R', 'G', 'r', 't', 2, 12, 3, 1});  // team 12 player 3 again: manual unpenalise
  send({'R', 'G', 'r', 't', 2, 12});                                 // short
  send(std::vector<std::uint8_t>(1500, 0xff));                       // large garbage
  send({});                                                          // empty datagram
  send({'R', 'G', 'm', 'e', 2, 12, 3, 2});                           // foreign header
  send({'R', 'G', 'r', 't', 4, 12, 3, 2});                           // other version
  send({'R', 'G', 'r', 't', 2, 99, 3, 2});                           // a team not in this game
  send({'R', 'G', 'r', 't', 2, 12, 0, 2});                           // player 0
  send({'R', 'G', 'r', 't', 2, 12, 12, 2});                          // player 12

  ASSERT_TRUE(eventually([&] {
    const gc::GameControllerCounters c = controller->counters();
    return c.returns + c.wrong_size + c.wrong_header + c.wrong_version + c.unknown_robot == 11;
  }));
  const gc::GameControllerCounters c = controller->counters();
  EXPECT_EQ(c.returns, 3u);
  EXPECT_EQ(c.wrong_size, 3u);
  EXPECT_EQ(c.wrong_header, 1u);
  EXPECT_EQ(c.wrong_version, 1u);
  EXPECT_EQ(c.unknown_robot, 3u);

  const std::optional<gc::ReturnRecord> a3 = controller->last_return(12, 3);
  ASSERT_TRUE(a3);
  EXPECT_EQ(a3->message, gc::kReturnManUnpenalise);
  EXPECT_EQ(a3->count, 2u);
  const std::optional<gc::ReturnRecord> b1 = controller->last_return(34, 1);
  ASSERT_TRUE(b1);
  EXPECT_EQ(b1->message, gc::kReturnManPenalise);
  EXPECT_FALSE(controller->last_return(99, 3));
  EXPECT_FALSE(controller->last_return(12, 1));
  controller->stop();
}

TEST(Game, SetPlaysAndTimeoutsFillTheSecondaryState) {
  gc::Game game(options_for(gc::kDataPort));
  EXPECT_NE(game.secondary(gc::SecondaryState::kDirectFreekick, 0), "");  // not in INITIAL
  EXPECT_EQ(game.secondary(gc::SecondaryState::kTimeout, 1), "");
  EXPECT_EQ(game.data().secondary_state, gc::SecondaryState::kTimeout);
  EXPECT_EQ(game.data().secondary_state_info[0], 34);
  EXPECT_EQ(game.secondary(gc::SecondaryState::kNormal, -1), "");
  EXPECT_EQ(game.data().secondary_state, gc::SecondaryState::kNormal);
  EXPECT_EQ(game.ready(), "");
  EXPECT_EQ(game.set(), "");
  EXPECT_EQ(game.play(), "");
  EXPECT_NE(game.secondary(gc::SecondaryState::kTimeout, 0), "");  // not while PLAYING
  EXPECT_NE(game.secondary(gc::SecondaryState::kCornerKick, 2), "");
  EXPECT_NE(game.secondary(gc::SecondaryState::kPenaltyShoot, 0), "");
  EXPECT_EQ(game.secondary(gc::SecondaryState::kCornerKick, 0, 1), "");
  EXPECT_EQ(game.data().secondary_state, gc::SecondaryState::kCornerKick);
  EXPECT_EQ(game.data().secondary_state_info, (std::array<std::uint8_t, 4>{12, 1, 0, 0}));
}

// The test plays another GameController on the network: its packet reaches the watch (a loopback
// port here, a broadcast address in doppel), and the controller stops sending until told to go on.
TEST(GameController, StepsAsideWhenAnotherGameControllerSends) {
  std::string error;
  std::optional<gc::UdpSocket> robot = gc::UdpSocket::open(kLoopback, 0, false, error);
  ASSERT_TRUE(robot) << error;
  gc::GameControllerOptions options = options_for(robot->local_port());
  options.watch_address = "127.0.0.1";
  options.watch_port = 0;
  std::atomic<int> told{0};
  options.on_step_aside = [&told](const std::string&) { ++told; };
  std::unique_ptr<gc::GameController> controller = gc::GameController::create(options, error);
  ASSERT_NE(controller, nullptr) << error;
  ASSERT_NE(controller->watch_port(), 0) << controller->watch_error();
  controller->start();
  std::vector<std::uint8_t> buffer(2048);
  ASSERT_TRUE(robot->receive(buffer, 2000ms));

  std::optional<gc::UdpSocket> other = gc::UdpSocket::open(kLoopback, 0, false, error);
  ASSERT_TRUE(other) << error;
  const gc::Endpoint watch{kLoopback, controller->watch_port()};
  // Not a GameController packet: ignored.
  ASSERT_TRUE(other->send_to(watch, std::vector<std::uint8_t>{'R', 'G', 'r', 't', 2, 1, 1, 2}, error));
  std::vector<std::uint8_t> foreign(688, 0);  // "RGme", version 12, teams 5 and 6, all else 0 (INITIAL)
  foreign[0] = 'R', foreign[1] = 'G', foreign[2] = 'm', foreign[3] = 'e', foreign[4] = 12;
  foreign[24] = 5;
  foreign[24 + 332] = 6;
  std::this_thread::sleep_for(300ms);
  EXPECT_TRUE(controller->sending());
  ASSERT_TRUE(other->send_to(watch, foreign, error)) << error;
  ASSERT_TRUE(eventually([&] { return !controller->sending(); }));
  EXPECT_EQ(told.load(), 1);
  EXPECT_NE(controller->stepped_aside().find("127.0.0.1:" + std::to_string(other->local_port())), std::string::npos)
      << controller->stepped_aside();
  ASSERT_TRUE(controller->foreign());
  EXPECT_EQ(controller->foreign()->last.teams[0].team_number, 5);
  // Nothing more reaches the robot (one packet may have been on its way).
  while (robot->receive(buffer, 100ms)) {
  }
  EXPECT_FALSE(robot->receive(buffer, 1200ms));
  // Told to go on, it sends again.
  controller->set_sending(true);
  EXPECT_EQ(controller->stepped_aside(), "");
  ASSERT_TRUE(robot->receive(buffer, 2000ms));
  EXPECT_EQ(std::string(buffer.begin(), buffer.begin() + 4), "RGme");
  controller->stop();
}

TEST(GameController, AWatchThatCannotBindIsReportedNotFatal) {
  std::string error;
  std::optional<gc::UdpSocket> taken = gc::UdpSocket::open(kLoopback, 0, false, error);  // no SO_REUSEADDR
  ASSERT_TRUE(taken) << error;
  gc::GameControllerOptions options = options_for(taken->local_port());
  options.watch_address = "127.0.0.1";
  options.watch_port = taken->local_port();
  std::unique_ptr<gc::GameController> controller = gc::GameController::create(options, error);
  ASSERT_NE(controller, nullptr) << error;
  EXPECT_EQ(controller->watch_port(), 0);
  EXPECT_NE(controller->watch_error().find("cannot bind"), std::string::npos) << controller->watch_error();
}
