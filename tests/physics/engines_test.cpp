// The engine choice: each Engine has its command-line name and builds its own backend; an unknown
// name is refused with the known ones.
#include "physics/engines.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

namespace doppel::physics {
namespace {

TEST(Engines, EachEngineBuildsTheBackendOfItsName) {
  for (Engine engine : kEngines) {
    const auto sut = make_backend(engine);

    EXPECT_EQ(sut->name(), engine_name(engine));
    EXPECT_EQ(engine_from_name(engine_name(engine)), engine);
  }
  EXPECT_EQ(engine_name(Engine::kOde), "ode");
  EXPECT_EQ(engine_name(Engine::kBullet), "bullet");
  EXPECT_EQ(engine_names(), (std::vector<std::string>{"ode", "bullet"}));
}

TEST(Engines, UnknownNameIsRefusedWithTheKnownOnes) {
  try {
    engine_from_name("mujoco");
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("'mujoco'"), std::string::npos) << message;
    EXPECT_NE(message.find("ode, bullet"), std::string::npos) << message;
  }
  EXPECT_THROW(engine_from_name("none"), std::invalid_argument);
}

}  // namespace
}  // namespace doppel::physics
