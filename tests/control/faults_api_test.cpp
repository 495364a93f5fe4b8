// /api/faults (control/http_api.h) against a recording simulation with faults: a good request reaches
// add_fault with every field as given, a bad one gets 400 naming its field and reaches nothing,
// DELETE clears one or all, and a simulation without faults (a replay) answers 404.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "control/http_api.h"
#include "null_simulation.h"

namespace doppel::control {
namespace {

using nlohmann::json;

class FaultControl final : public testing::NullSimulation, public contract::Faults {
 public:
  contract::SimState state() override {
    contract::SimState s;
    s.sim_time_s = 2.0;
    contract::RobotState a;
    a.name = "fumanoid-2011";
    a.simulated = true;
    s.robots = {a};
    return s;
  }
  // A replay offers no faults (serves = false).
  contract::Facets facets() {
    contract::Facets facets;
    facets.simulation = this;
    if (serves) facets.faults = this;
    return facets;
  }

  contract::FaultList faults() override {
    contract::FaultList list;
    list.sim_time_s = 2.0;
    for (const faults::Fault& f : added) list.faults.push_back({f, f.active_at(2'000'000'000), f.end_ns <= 2'000'000'000});
    return list;
  }
  contract::Result<uint32_t> add_fault(const faults::FaultSpec& spec) override {
    faults::Fault f;
    f.number = static_cast<uint32_t>(added.size() + 1);
    f.spec = spec;
    f.start_ns = spec.start_ns == faults::kNow ? 2'000'000'000 : spec.start_ns;
    f.end_ns = spec.duration_ns == 0 ? INT64_MAX : f.start_ns + spec.duration_ns;
    added.push_back(f);
    return f.number;
  }
  contract::Outcome clear_fault(uint32_t number) override {
    cleared.push_back(number);
    return {};
  }
  contract::Outcome clear_faults() override {
    cleared.push_back(0);
    return {};
  }

  bool serves = true;
  std::vector<faults::Fault> added;
  std::vector<uint32_t> cleared;
};

TEST(FaultsApi, AServoFaultReachesTheSimulationWithEveryFieldAndIsListed) {
  FaultControl control;
  const Answer answer = handle(control.facets(), "POST", "/api/faults",
                               R"({"kind": "overheat", "robot": "fumanoid-2011", "bus": 0, "id": 14,
                                   "rise_c_per_s": 5, "start_s": 12, "duration_s": 0.3, "seed": 7})");
  ASSERT_EQ(answer.status, 200) << answer.body.dump();
  ASSERT_EQ(control.added.size(), 1u);
  const faults::FaultSpec& spec = control.added[0].spec;
  EXPECT_EQ(spec.kind, faults::FaultKind::kOverheat);
  EXPECT_EQ(spec.robot, 0u);
  EXPECT_EQ(spec.bus, 0);
  EXPECT_EQ(spec.id, 14);
  EXPECT_EQ(spec.value, 5.0);
  EXPECT_EQ(spec.start_ns, 12'000'000'000);
  EXPECT_EQ(spec.duration_ns, 300'000'000);
  EXPECT_EQ(spec.seed, 7u);
  EXPECT_EQ(answer.body["added"], 1);
  ASSERT_EQ(answer.body["faults"].size(), 1u);
  const json& listed = answer.body["faults"][0];
  EXPECT_EQ(listed["kind"], "overheat");
  EXPECT_EQ(listed["scope"], "servo");
  EXPECT_EQ(listed["rise_c_per_s"], 5.0);
  EXPECT_DOUBLE_EQ(listed["start_s"].get<double>(), 12.0);
  EXPECT_DOUBLE_EQ(listed["end_s"].get<double>(), 12.3);
  EXPECT_EQ(listed["active"], false) << "it starts at 12 s, the simulation is at 2 s";
  EXPECT_EQ(answer.body["kinds"].size(), faults::kFaultKinds);
}

TEST(FaultsApi, WithoutStartItStartsNowAndWithoutDurationItLastsUntilCleared) {
  FaultControl control;
  const Answer answer = handle(control.facets(), "POST", "/api/faults", R"({"kind": "drop", "robot": 0, "bus": 0, "rate": 0.01})");
  ASSERT_EQ(answer.status, 200) << answer.body.dump();
  EXPECT_EQ(control.added[0].spec.start_ns, faults::kNow);
  EXPECT_EQ(control.added[0].spec.duration_ns, faults::kForever);
  EXPECT_EQ(answer.body["faults"][0]["end_s"], nullptr);
  EXPECT_EQ(answer.body["faults"][0]["active"], true);
}

TEST(FaultsApi, ABadRequestNamesItsFieldAndAddsNothing) {
  FaultControl control;
  struct Case {
    const char* body;
    int status;
    const char* names;
  };
  const std::vector<Case> cases = {
      {R"({"robot": 0})", 400, "'kind'"},
      {R"({"kind": "melt", "robot": 0})", 400, "'kind'"},
      {R"({"kind": 3, "robot": 0})", 400, "'kind'"},
      {R"({"kind": "overheat", "bus": 0, "id": 1, "rise_c_per_s": 1})", 400, "'robot'"},
      {R"({"kind": "overheat", "robot": 5, "bus": 0, "id": 1, "rise_c_per_s": 1})", 404, "no robot 5"},
      {R"({"kind": "overheat", "robot": 0, "id": 1, "rise_c_per_s": 1})", 400, "'bus'"},
      {R"({"kind": "overheat", "robot": 0, "bus": 0, "rise_c_per_s": 1})", 400, "'id'"},
      {R"({"kind": "overheat", "robot": 0, "bus": 0, "id": 1})", 400, "'rise_c_per_s'"},
      {R"({"kind": "overheat", "robot": 0, "bus": 0, "id": 1, "rise_c_per_s": 0})", 400, "'rise_c_per_s'"},
      {R"({"kind": "overheat", "robot": 0, "bus": 0, "id": 1, "rise_c_per_s": "hot"})", 400, "'rise_c_per_s'"},
      {R"({"kind": "overheat", "robot": 0, "bus": 0, "id": 1, "rise_c_per_s": 1, "volts": 3})", 400, "'volts'"},
      {R"({"kind": "overheat", "robot": 0, "bus": 0, "id": 254, "rise_c_per_s": 1})", 400, "'id'"},
      {R"({"kind": "overheat", "robot": 0, "bus": -1, "id": 1, "rise_c_per_s": 1})", 400, "'bus'"},
      {R"({"kind": "overheat", "robot": 0, "bus": 0, "id": 1, "rise_c_per_s": 1, "start_s": -1})", 400, "'start_s'"},
      {R"({"kind": "overheat", "robot": 0, "bus": 0, "id": 1, "rise_c_per_s": 1, "duration_s": -0.5})", 400, "'duration_s'"},
      {R"({"kind": "overheat", "robot": 0, "bus": 0, "id": 1, "rise_c_per_s": 1, "seed": -3})", 400, "'seed'"},
      {R"({"kind": "corrupt", "robot": 0, "bus": 0})", 400, "'rate'"},
      {R"({"kind": "corrupt", "robot": 0, "bus": 0, "rate": 1.5})", 400, "'rate'"},
      {R"({"kind": "corrupt", "robot": 0, "bus": 0, "rate": 0.1, "id": 3})", 400, "'id'"},
      {R"({"kind": "collision", "robot": 0, "bus": 0, "rate": 0.1})", 400, "'id'"},
      {R"({"kind": "brownout", "robot": 0, "bus": 0, "volts": 9})", 400, "'bus'"},
      {R"({"kind": "brownout", "robot": 0, "volts": 30})", 400, "'volts'"},
      {R"({"kind": "weak", "robot": 0, "bus": 0, "id": 15, "scale": 1.2})", 400, "'scale'"},
      {R"({"kind": "imu_bias", "robot": 0, "bus": 0, "bias": 0.1})", 400, "'bus' and 'id'"},
      {R"({"kind": "silent", "robot": 0, "bus": 0, "colour": 1})", 400, "'colour'"},
      {R"([1, 2])", 400, "JSON object"},
      {R"({"kind": )", 400, "not JSON"},
  };
  for (const Case& c : cases) {
    const Answer answer = handle(control.facets(), "POST", "/api/faults", c.body);
    EXPECT_EQ(answer.status, c.status) << c.body << " -> " << answer.body.dump();
    ASSERT_TRUE(answer.body.contains("error")) << c.body;
    EXPECT_NE(answer.body["error"].get<std::string>().find(c.names), std::string::npos)
        << c.body << " -> " << answer.body["error"];
  }
  EXPECT_TRUE(control.added.empty()) << "a refused fault reaches nothing";
  EXPECT_EQ(handle(control.facets(), "GET", "/api/faults", "").body["faults"].size(), 0u);
}

TEST(FaultsApi, DeleteClearsOneOrAll) {
  FaultControl control;
  ASSERT_EQ(handle(control.facets(), "POST", "/api/faults", R"({"kind": "silent", "robot": 0, "bus": 0})").status, 200);
  EXPECT_EQ(handle(control.facets(), "DELETE", "/api/faults/1", "").status, 200);
  EXPECT_EQ(handle(control.facets(), "DELETE", "/api/faults", "").status, 200);
  EXPECT_EQ(control.cleared, (std::vector<uint32_t>{1, 0}));
  EXPECT_EQ(handle(control.facets(), "DELETE", "/api/faults/x1", "").status, 404);
  EXPECT_EQ(handle(control.facets(), "POST", "/api/faults/1", "").status, 405);
  EXPECT_EQ(handle(control.facets(), "PUT", "/api/faults", "{}").status, 405);
  EXPECT_EQ(control.cleared.size(), 2u);
}

TEST(FaultsApi, ASimulationWithoutFaultsAnswers404) {
  FaultControl control;
  control.serves = false;
  EXPECT_EQ(handle(control.facets(), "GET", "/api/faults", "").status, 404);
  EXPECT_EQ(handle(control.facets(), "POST", "/api/faults", R"({"kind": "silent", "robot": 0, "bus": 0})").status, 404);
  EXPECT_TRUE(control.added.empty());
}

}  // namespace
}  // namespace doppel::control
