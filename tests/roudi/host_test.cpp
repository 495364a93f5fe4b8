// roudi::Host, the one iceoryx of a process that doppel's cameras and its truth transport share:
// both get the same host, RouDi stops with the last holder and a later user starts it again, asked
// pools are there, and a RouDi that is wanted but missing is refused by name.
#include <gtest/gtest.h>

#include <memory>
#include <stdexcept>
#include <string>

#include "roudi/host.h"

namespace doppel::roudi {
namespace {

TEST(RouDiHost, EveryUserOfAProcessSharesTheOneHost) {
  ASSERT_FALSE(running()) << "another RouDi runs on this machine; this test needs to start its own";
  HostOptions cameras;
  cameras.pools = {{614400, 8}};

  std::shared_ptr<Host> first = Host::share(cameras);
  std::shared_ptr<Host> second = Host::share(HostOptions{});

  EXPECT_EQ(first.get(), second.get());
  EXPECT_TRUE(first->in_process());
  EXPECT_TRUE(running());
  EXPECT_TRUE(Host::exists());
  first.reset();
  EXPECT_TRUE(running()) << "RouDi stopped while the second user still holds the host";
  second.reset();
  EXPECT_FALSE(Host::exists());
  EXPECT_FALSE(running());
}

TEST(RouDiHost, ALaterUserStartsRouDiAgainWithItsOwnPools) {
  ASSERT_FALSE(running());
  Host::share(HostOptions{}).reset();
  HostOptions options;
  options.pools = {{614400, 8}, {614400, 4}};

  const std::shared_ptr<Host> sut = Host::share(options);

  ASSERT_TRUE(sut->in_process());
  EXPECT_EQ(sut->pools().at(614400), 12u);  // chunks of one size add up
  EXPECT_GE(sut->max_payload_bytes(), 614400u);
  uint64_t bytes = 0;
  for (const auto& [payload, chunks] : sut->pools()) bytes += (uint64_t{payload} + 128) * chunks;
  EXPECT_EQ(sut->pool_bytes(), bytes);
}

TEST(RouDiHost, AnExternalRouDiThatIsNotRunningIsRefusedByName) {
  ASSERT_FALSE(running());
  HostOptions options;
  options.mode = Mode::kExternal;

  try {
    Host::share(options);
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("no RouDi runs on this machine"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(Host::exists());
  EXPECT_FALSE(running());
}

TEST(RouDiHost, AProcessWithAHostDoesNotRegisterAsAClientToo) {
  ASSERT_FALSE(running());
  const std::shared_ptr<Host> host = Host::share(HostOptions{});

  register_client("doppel-roudi-test");

  EXPECT_FALSE(client_registered());
  EXPECT_TRUE(host->in_process());
}

}  // namespace
}  // namespace doppel::roudi
