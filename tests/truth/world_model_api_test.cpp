// GET/PUT /api/robots/N/world_model (control/http_api.h) against a world-model facet that keeps the
// settings: a change names only the fields it changes, a field of the wrong type or an unknown one
// is refused naming it before anything changes, and a simulation without the sensor answers 404.
#include <gtest/gtest.h>

#include <optional>
#include <string>

#include "control/http_api.h"
#include "null_simulation.h"
#include "truth/world_model.h"

namespace doppel::control {
namespace {

class Control : public testing::NullSimulation {
 public:
  // The simulation alone: no world-model sensor.
  virtual contract::Facets facets() {
    contract::Facets facets;
    facets.simulation = this;
    return facets;
  }
};

// One robot (index 1) with a sensor, checked as doppel checks it (truth::settings_problem).
class WithSensor final : public Control, public contract::WorldModel {
 public:
  contract::Result<contract::WorldModelSettings> world_model(std::size_t robot) override {
    if (robot != 1) return contract::Error{contract::ErrorKind::kNotFound, "robot " + std::to_string(robot) + " has no world-model sensor"};
    return settings;
  }
  contract::Result<contract::WorldModelSettings> set_world_model(std::size_t robot, const contract::WorldModelSettings& s) override {
    ++changes;
    if (robot != 1) return world_model(robot);
    if (const std::string problem = truth::settings_problem(s); !problem.empty()) {
      return contract::Error{contract::ErrorKind::kInvalid, problem};
    }
    settings = s;
    return settings;
  }
  contract::Facets facets() override {
    contract::Facets facets = Control::facets();
    facets.world_model = this;
    return facets;
  }
  contract::WorldModelSettings settings;
  int changes = 0;
};

TEST(WorldModelApi, GetShowsEverySettingAndPutChangesOnlyTheFieldsNamed) {
  WithSensor control;
  Answer got = handle(control.facets(), "GET", "/api/robots/1/world_model", "");
  ASSERT_EQ(got.status, 200) << got.body;
  EXPECT_EQ(got.body["robot"], 1);
  EXPECT_EQ(got.body["rate_hz"], 30.0);
  EXPECT_EQ(got.body["fov_deg"], 0.0);
  EXPECT_EQ(got.body["nearest_ball_only"], false);
  EXPECT_EQ(got.body.size(), 11u);

  Answer put = handle(control.facets(), "PUT", "/api/robots/1/world_model", R"({"fov_deg": 90, "dropout": 0.25, "seed": 12})");
  ASSERT_EQ(put.status, 200) << put.body;
  EXPECT_EQ(put.body["fov_deg"], 90.0);
  EXPECT_EQ(put.body["dropout"], 0.25);
  EXPECT_EQ(put.body["seed"], 12);
  EXPECT_EQ(put.body["rate_hz"], 30.0) << "a field not named stays";
  EXPECT_EQ(control.settings.fov_deg, 90.0);
  EXPECT_EQ(control.settings.seed, 12u);
}

TEST(WorldModelApi, BadRequestsAreRefusedNamingTheField) {
  WithSensor control;
  auto refused = [&](const std::string& body, int status, const std::string& names) {
    const int before = control.changes;
    const Answer a = handle(control.facets(), "PUT", "/api/robots/1/world_model", body);
    EXPECT_EQ(a.status, status) << body << " -> " << a.body;
    EXPECT_NE(a.body.value("error", std::string()).find(names), std::string::npos) << body << " -> " << a.body;
    return control.changes - before;
  };
  EXPECT_EQ(refused(R"({"fov_deg": "wide"})", 400, "fov_deg"), 0);
  EXPECT_EQ(refused(R"({"nearest_ball_only": 1})", 400, "nearest_ball_only"), 0);
  EXPECT_EQ(refused(R"({"seed": -3})", 400, "seed"), 0);
  EXPECT_EQ(refused(R"({"colour": "red"})", 400, "colour"), 0);
  EXPECT_EQ(refused("[1]", 400, "object"), 0);
  refused(R"({"fov_deg": 190})", 400, "fov_deg");  // the range is the sensor's to check
  refused(R"({"dropout": 1})", 400, "dropout");
  EXPECT_EQ(control.settings.fov_deg, 0.0) << "nothing changed";
  EXPECT_EQ(handle(control.facets(), "PUT", "/api/robots/0/world_model", "{}").status, 404);
  EXPECT_EQ(handle(control.facets(), "POST", "/api/robots/1/world_model", "{}").status, 405);
  EXPECT_EQ(handle(control.facets(), "GET", "/api/robots/x/world_model", "").status, 404);
}

TEST(WorldModelApi, ASimulationWithoutTheSensorAnswers404) {
  Control control;
  const Answer a = handle(control.facets(), "GET", "/api/robots/0/world_model", "");
  EXPECT_EQ(a.status, 404);
  EXPECT_NE(a.body["error"].get<std::string>().find("--world-model"), std::string::npos) << a.body;
}

}  // namespace
}  // namespace doppel::control
