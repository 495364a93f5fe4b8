// The world-model sensor over iceoryx: doppel starts RouDi for it (also with --no-camera), and a
// client receives over iceoryx what goes out over UDP, message for message. Holds the RouDi lock
// (docs/testing.md: or run it under unshare -m with fresh tmpfs on /dev/shm and /tmp).
#include <gtest/gtest.h>

#include <optional>
#include <string>

#include "camera/client.h"
#include "truth_doppel.h"

namespace doppel::testing {
namespace {

TEST(WorldModelDoppelIceoryx, IceoryxAndUdpBothReceiveTheSameMessages) {
  TruthDoppel doppel({"--physics", "ode"}, /*iceoryx=*/true);
  ASSERT_NE(doppel.doppel.output().find("iceoryx (DoppelTruth, robot<N>, world_model)"), std::string::npos)
      << doppel.doppel.output();
  camera::connect_client("doppel-truth-test");
  truth::IceoryxSubscriber subscriber(0, "world_model");
  std::optional<WorldModel> first;
  for (int i = 0; i < 60 && !first; ++i) {
    if (const std::optional<std::string> bytes = subscriber.take(1.0)) {
      first.emplace();
      ASSERT_TRUE(first->ParseFromString(*bytes));
    }
  }
  ASSERT_TRUE(first) << "nothing over iceoryx; " << doppel.doppel.output();
  // A later message over iceoryx is also seen over UDP, byte for byte the same content.
  std::optional<std::string> later;
  WorldModel over_iceoryx;
  for (int i = 0; i < 10; ++i) {
    later = subscriber.take(5.0);
    ASSERT_TRUE(later);
    ASSERT_TRUE(over_iceoryx.ParseFromString(*later));
    if (over_iceoryx.sequence() > first->sequence() + 3) break;
  }
  const WorldModel over_udp = doppel.next([&](const WorldModel& w) { return w.sequence() == over_iceoryx.sequence(); });
  EXPECT_EQ(over_udp.SerializeAsString(), *later);
  EXPECT_EQ(over_iceoryx.balls_size(), 1);
}

}  // namespace
}  // namespace doppel::testing
