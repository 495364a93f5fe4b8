#include "dynamixel/control_table.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "dynamixel/models.h"
#include "dynamixel/protocol1_servo.h"
#include "test_support.h"

namespace doppel::dynamixel {
namespace {

using testing::make_packet;
using testing::transact;

// One register row as printed in reference §3.4 / §3.5.
struct Row {
  uint8_t address;
  uint8_t size;
  Access access;
  Area area;
  int32_t default_raw;  // kNoDefault: not checked here (power-on rules, measured values)
  int32_t min_raw;      // writable range (RW rows)
  int32_t max_raw;
};
constexpr int32_t kNoDefault = -100000;
constexpr Access R = Access::kRead;
constexpr Access RW = Access::kReadWrite;
constexpr Area E = Area::kEeprom;
constexpr Area M = Area::kRam;

// The rows §3.4 (AX/RX) and §3.5 (MX) print alike, up to the per-model values given here; the rows
// where the two families differ are added by axrx_rows() and mx_rows().
std::vector<Row> shared_rows(int model, int baud, int position_max_raw, int temperature_limit, int max_voltage) {
  return {
      {0, 2, R, E, model, 0, 0},
      {3, 1, RW, E, 1, 0, 253},
      {4, 1, RW, E, baud, 0, 254},
      {5, 1, RW, E, 250, 0, 254},
      {6, 2, RW, E, 0, 0, position_max_raw},
      {8, 2, RW, E, position_max_raw, 0, position_max_raw},
      {11, 1, RW, E, temperature_limit, 0, 150},
      {12, 1, RW, E, 60, 50, 250},
      {13, 1, RW, E, max_voltage, 50, 250},
      {14, 2, RW, E, 1023, 0, 1023},
      {16, 1, RW, E, 2, 0, 2},
      {17, 1, RW, E, 36, 0, 127},
      {18, 1, RW, E, 36, 0, 127},
      {24, 1, RW, M, 0, 0, 1},
      {25, 1, RW, M, 0, 0, 1},
      {30, 2, RW, M, kNoDefault, 0, position_max_raw},
      {32, 2, RW, M, 0, 0, 1023},  // joint mode (default limits); 2047 in wheel mode
      {34, 2, RW, M, 1023, 0, 1023},
      {36, 2, R, M, kNoDefault, 0, 0},
      {38, 2, R, M, kNoDefault, 0, 0},
      {40, 2, R, M, kNoDefault, 0, 0},
      {42, 1, R, M, kNoDefault, 0, 0},
      {43, 1, R, M, kNoDefault, 0, 0},
      {44, 1, R, M, 0, 0, 0},
      {46, 1, R, M, 0, 0, 0},
      {47, 1, RW, M, 0, 0, 1},
  };
}

// Reference §3.4, one column of defaults per model.
std::vector<Row> axrx_rows(int model, int baud, int temperature_limit, int max_voltage) {
  std::vector<Row> rows = shared_rows(model, baud, 1023, temperature_limit, max_voltage);
  rows.insert(rows.end(), {
                              {20, 2, R, E, kNoDefault, 0, 0},
                              {22, 2, R, E, kNoDefault, 0, 0},
                              {26, 1, RW, M, 1, 0, 254},
                              {27, 1, RW, M, 1, 0, 254},
                              {28, 1, RW, M, 32, 1, 254},
                              {29, 1, RW, M, 32, 1, 254},
                              {48, 2, RW, M, 32, 32, 1023},
                          });
  return rows;
}

// Reference §3.5.
std::vector<Row> mx_rows(int model, int max_voltage, bool current_items, bool drive_mode) {
  std::vector<Row> rows = shared_rows(model, 34, 4095, 80, max_voltage);
  rows.insert(rows.end(), {
                              {20, 2, RW, E, 0, -24576, 24576},
                              {22, 1, RW, E, 1, 1, 4},
                              {26, 1, RW, M, 0, 0, 254},
                              {27, 1, RW, M, 0, 0, 254},
                              {28, 1, RW, M, 32, 0, 254},
                              {48, 2, RW, M, 0, 0, 1023},
                              {50, 2, R, M, 0, 0, 0},
                              {73, 1, RW, M, 0, 0, 254},
                          });
  if (current_items) {
    rows.push_back({70, 1, RW, M, 0, 0, 1});
    rows.push_back({71, 2, RW, M, 0, 0, 2047});
  }
  if (drive_mode) {
    rows.push_back({10, 1, RW, E, 0, 0, 3});
  }
  return rows;
}

struct ModelRows {
  const char* model;
  std::vector<Row> rows;
};

std::vector<ModelRows> all_rows() {
  return {
      {"AX-12A", axrx_rows(12, 1, 70, 140)},
      {"RX-28", axrx_rows(28, 34, 80, 190)},
      {"RX-64", axrx_rows(64, 34, 80, 190)},
      {"MX-28", mx_rows(29, 160, false, false)},
      {"MX-64", mx_rows(310, 240, true, false)},
      {"MX-106", mx_rows(320, 160, true, true)},
  };
}

// A factory-fresh servo: ID 1, the model's default baud rate and Return Delay Time.
Protocol1Servo factory_servo(const ModelSpec& spec) {
  const RegisterSpec* baud = find_register(spec.registers, p1::kBaudRate);
  return Protocol1Servo(spec, 1, static_cast<uint8_t>(baud->default_raw), 250);
}

uint8_t write_error(const ModelSpec& spec, const Row& row, int32_t value) {
  auto sut = factory_servo(spec);
  const auto raw = static_cast<uint16_t>(value);
  const auto reply = row.size == 2
                         ? transact(sut, make_packet(1, instruction::kWrite,
                                                     {row.address, static_cast<uint8_t>(raw & 0xFF),
                                                      static_cast<uint8_t>(raw >> 8)}))
                         : transact(sut, make_packet(1, instruction::kWrite, {row.address, static_cast<uint8_t>(raw)}));
  return reply.size() == 6 ? reply[4] : 0xFF;
}

TEST(ControlTable, LayoutMatchesReference) {
  for (const auto& [model, rows] : all_rows()) {
    const ModelSpec& spec = model_spec(model);
    for (const Row& row : rows) {
      const RegisterSpec* r = find_register(spec.registers, row.address);
      ASSERT_NE(r, nullptr) << model << " @" << int(row.address);
      EXPECT_EQ(r->address, row.address) << model << " @" << int(row.address);
      EXPECT_EQ(r->size, row.size) << model << " @" << int(row.address);
      EXPECT_EQ(r->access, row.access) << model << " @" << int(row.address);
      EXPECT_EQ(r->area, row.area) << model << " @" << int(row.address);
    }
  }
}

TEST(ControlTable, FactoryDefaultsMatchReference) {
  for (const auto& [model, rows] : all_rows()) {
    const ModelSpec& spec = model_spec(model);
    const auto sut = factory_servo(spec);
    for (const Row& row : rows) {
      if (row.default_raw != kNoDefault) {
        EXPECT_EQ(static_cast<int16_t>(sut.register_raw(row.address)), row.default_raw)
            << model << " @" << int(row.address);
      }
    }
  }
}

TEST(ControlTable, WritableRangesMatchReference) {
  for (const auto& [model, rows] : all_rows()) {
    const ModelSpec& spec = model_spec(model);
    for (const Row& row : rows) {
      const std::string where = std::string(model) + " @" + std::to_string(row.address);
      if (row.access == R) {
        EXPECT_EQ(write_error(spec, row, 0), p1_error::kRange) << where;
        continue;
      }
      EXPECT_EQ(write_error(spec, row, row.min_raw), 0) << where;
      EXPECT_EQ(write_error(spec, row, row.max_raw), 0) << where;
      if (row.max_raw < (row.size == 2 ? 0xFFFF : 0xFF)) {
        EXPECT_EQ(write_error(spec, row, row.max_raw + 1), p1_error::kRange) << where;
      }
      if (row.min_raw > 0 || row.min_raw < 0) {
        EXPECT_EQ(write_error(spec, row, row.min_raw - 1), p1_error::kRange) << where;
      }
    }
  }
}

TEST(ControlTable, ReservedBytesReadZeroAndRejectWrites) {
  auto sut = factory_servo(model_spec("MX-28"));
  // MX-28 has nothing at 52..72 (Current, Torque Ctrl and Goal Torque are MX-64/106 only).
  const auto reply = transact(sut, make_packet(1, instruction::kRead, {68, 2}));
  ASSERT_EQ(reply.size(), 8u);
  EXPECT_EQ(reply[5], 0);
  EXPECT_EQ(reply[6], 0);
  EXPECT_EQ(transact(sut, make_packet(1, instruction::kWrite, {68, 0, 8}))[4], p1_error::kRange);
  EXPECT_EQ(transact(sut, make_packet(1, instruction::kWrite, {10, 1}))[4], p1_error::kRange);
}

TEST(ControlTable, TableEndsAtLastRegister) {
  auto ax = factory_servo(model_spec("AX-12A"));
  auto mx = factory_servo(model_spec("MX-64"));
  EXPECT_EQ(transact(ax, make_packet(1, instruction::kRead, {48, 2})).size(), 8u);
  EXPECT_EQ(transact(ax, make_packet(1, instruction::kRead, {50, 1}))[4], p1_error::kRange);
  EXPECT_EQ(transact(mx, make_packet(1, instruction::kRead, {73, 1})).size(), 7u);
  EXPECT_EQ(transact(mx, make_packet(1, instruction::kRead, {74, 1}))[4], p1_error::kRange);
  EXPECT_EQ(transact(mx, make_packet(1, instruction::kRead, {0, 0}))[4], p1_error::kRange);
}

TEST(ControlTable, RegistersAreSortedAndDoNotOverlap) {
  for (const ModelSpec* spec : known_models()) {
    int next_free = 0;
    for (const RegisterSpec& r : spec->registers) {
      EXPECT_GE(r.address, next_free) << spec->name << " " << r.name;
      EXPECT_LE(r.address + r.size, spec->table_bytes) << spec->name << " " << r.name;
      EXPECT_LE(r.min_raw, r.max_raw) << spec->name << " " << r.name;
      next_free = r.address + r.size;
    }
  }
}

}  // namespace
}  // namespace doppel::dynamixel
