// A driver opens the port the moment its link appears and writes at once (scripts do; a real bus
// answers as soon as it is plugged in): doppel with its defaults (camera and RouDi, viewer,
// handshake, physics) publishes a port's link only once the port's bus thread serves it. Its own
// executable: it starts RouDi, so it holds the `roudi` lock.
//
// What is asserted is deterministic: the bus thread exists when the link appears, every request
// is answered with the reference's bytes, and doppel's own counters show one request and one
// status per check (the client never sent anything twice). How soon the answer comes is a timing
// figure: bench/first_answer measures it (docs/benchmarks.md).
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "reference_client.h"
#include "reference_client_p2.h"
#include "watched_doppel.h"

namespace doppel::testing {
namespace {

constexpr int kHangGuardMs = 20'000;  // only against a hang: no timing is asserted

int count_of(const std::vector<std::string>& names, const std::string& name) {
  int n = 0;
  for (const std::string& each : names) n += each == name ? 1 : 0;
  return n;
}

// The bus counters doppel prints at exit for `link` must say: `requests` packets in, `replies` out.
void expect_counters(const std::string& output, const std::string& link, std::size_t bytes_in, std::size_t bytes_out,
                     int requests, int replies) {
  const std::size_t at = output.find(link + ": ");
  ASSERT_NE(at, std::string::npos) << output;
  const std::string counters = output.substr(at);
  EXPECT_EQ(counters.find(link + ": 1 client sessions, " + std::to_string(bytes_in) + " bytes in, " +
                          std::to_string(bytes_out) + " bytes out"),
            0u)
      << counters;
  EXPECT_NE(counters.find("packets " + std::to_string(requests) + " ("), std::string::npos) << counters;
  EXPECT_NE(counters.find("replies " + std::to_string(replies) + " ("), std::string::npos) << counters;
}

// Reference §1 (table of examples): PING ID 1, and READ of addresses 0..2 of an RX-28 (model 28, fw 8).
const Bytes kPing1 = {0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB};
const Bytes kPing1Status = {0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC};
const Bytes kReadModelRx28 = {0xFF, 0xFF, 0x01, 0x04, 0x02, 0x00, 0x03, 0xF5};
const Bytes kReadModelRx28Status = {0xFF, 0xFF, 0x01, 0x05, 0x00, 0x1C, 0x00, 0x08, 0xD5};

TEST(FirstAnswer, TwentyDefaultStartsEachAnswerThePingSentTheMomentTheLinkAppears) {
  for (int run = 0; run < 20; ++run) {
    SCOPED_TRACE("start " + std::to_string(run + 1) + " of 20");
    WatchedDoppel doppel({});
    const std::string link = doppel.wait_for_link("ttyDXL0");
    // The default robot (fumanoid-2011) has one bus: its thread serves the port already.
    EXPECT_EQ(count_of(doppel.thread_names(), "doppel-bus"), 1);
    Bytes status;
    {
      SerialClient client(link, 1'000'000);
      client.send(kPing1);  // once: a retry would show in doppel's counters below
      status = client.receive(kPing1Status.size(), kHangGuardMs);
    }
    EXPECT_EQ(status, kPing1Status);
    const std::string output = doppel.stop();
    expect_counters(output, link, kPing1.size(), kPing1Status.size(), 1, 1);
    if (::testing::Test::HasFailure()) break;
  }
}

// A checking script in the style of the "bars" client: it opens the port the moment it
// appears, runs its Protocol 1.0 checks with no settle time, and takes the first bytes that come
// as each answer (a late status would be taken for the next check's answer).
TEST(FirstAnswer, ABarsStyleProtocol1ClientNeedsNoSettleTime) {
  WatchedDoppel doppel({});
  const std::string link = doppel.wait_for_link("ttyDXL0");
  std::size_t bytes_in = 0, bytes_out = 0;
  int requests = 0, replies = 0;
  {
    SerialClient client(link, 1'000'000);
    auto check = [&](const Bytes& request, const Bytes& expected) {
      client.send(request);
      EXPECT_EQ(client.receive(expected.size(), kHangGuardMs), expected);
      bytes_in += request.size();
      bytes_out += expected.size();
      ++requests;
      replies += expected.empty() ? 0 : 1;
    };
    check(kPing1, kPing1Status);
    check(kReadModelRx28, kReadModelRx28Status);
    for (uint8_t id : {2, 9, 21}) {  // RX-64s: model 64 (0x0040), reference §3.1
      const Bytes request = p1_instruction(id, 0x02, {0x00, 0x02});
      client.send(request);
      const auto statuses = parse_p1_statuses(client.receive(8, kHangGuardMs));
      ASSERT_TRUE(statuses.has_value());
      ASSERT_EQ(statuses->size(), 1u);
      EXPECT_EQ((*statuses)[0].id, id);
      EXPECT_EQ((*statuses)[0].error, 0);
      EXPECT_EQ((*statuses)[0].params, (Bytes{0x40, 0x00}));
      bytes_in += request.size();
      bytes_out += 8;
      ++requests;
      ++replies;
    }
    // ID 30 is not on the bus: no answer (the wire stays silent; a short drain is enough to see
    // that nothing came in place of the next answer).
    const Bytes absent = p1_instruction(30, 0x01);
    client.send(absent);
    bytes_in += absent.size();
    ++requests;
    check(kPing1, kPing1Status);
  }
  expect_counters(doppel.stop(), link, bytes_in, bytes_out, requests, replies);
}

// The same with Protocol 2.0 on the robot whose buses speak it (fumanoid-x430, 4 Mbps, camera on):
// both buses' links appear served, and PINGs answer with the XM430-W350's model number 1020.
TEST(FirstAnswer, ABarsStyleProtocol2ClientNeedsNoSettleTime) {
  WatchedDoppel doppel({"--robot", "fumanoid-x430"});
  const std::string link = doppel.wait_for_link("ttyDXL0");
  const std::vector<std::string> threads = doppel.thread_names();
  EXPECT_GE(count_of(threads, "doppel-bus"), 1);
  std::size_t bytes_in = 0, bytes_out = 0;
  int requests = 0;
  {
    SerialClient client(link, 4'000'000);
    for (int i = 0; i < 4; ++i) {
      const Bytes request = p2_instruction(1, 0x01);
      client.send(request);
      const Bytes answer = client.receive(14, kHangGuardMs);
      const auto statuses = parse_p2_statuses(answer);
      ASSERT_TRUE(statuses.has_value()) << "check " << i;
      ASSERT_EQ(statuses->size(), 1u);
      EXPECT_EQ((*statuses)[0].id, 1);
      EXPECT_EQ((*statuses)[0].error, 0);
      ASSERT_EQ((*statuses)[0].params.size(), 3u);
      EXPECT_EQ((*statuses)[0].params[0] | ((*statuses)[0].params[1] << 8), 1020);
      bytes_in += request.size();
      bytes_out += answer.size();
      ++requests;
    }
  }
  expect_counters(doppel.stop(), link, bytes_in, bytes_out, requests, requests);
}

// Under lockstep the simulation thread serves the buses (docs/lockstep.md): the links appear once
// it runs, after the clock file that `doppel-run --lockstep` needs.
TEST(FirstAnswer, UnderLockstepTheLinksAppearOnceTheSimulationThreadRuns) {
  WatchedDoppel doppel({"--lockstep"});
  doppel.wait_for_link("ttyDXL0");
  const std::vector<std::string> threads = doppel.thread_names();
  EXPECT_EQ(count_of(threads, "doppel-sim"), 1);
  EXPECT_EQ(count_of(threads, "doppel-bus"), 0) << "no bus threads under lockstep";
  const std::string output = doppel.stop();
  EXPECT_NE(output.find("lockstep: simulation time runs while controllers"), std::string::npos) << output;
}

}  // namespace
}  // namespace doppel::testing
