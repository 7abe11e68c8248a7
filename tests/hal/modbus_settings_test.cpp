// The Modbus driver's config block, and what connect() does when nothing answers.
#include "hal/modbus_cmm.hpp"

#include <chrono>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "hal/description/json_fields.hpp"

namespace cmm::hal {
namespace {

using ::testing::HasSubstr;
using ::testing::UnorderedElementsAre;

TEST(ModbusSettings, DefaultsAndEveryBadKey) {
  ModbusSettings s = modbus_settings_from_json({{"driver", "modbus"}, {"port", 1502}});
  EXPECT_EQ(s.transport, "tcp");
  EXPECT_EQ(s.port, 1502);
  EXPECT_DOUBLE_EQ(s.heartbeat_s, 0.1);
  try {
    modbus_settings_from_json({{"transport", "rtu"}, {"port", 0}, {"heartbeat_s", 2}, {"heartbeat_timeout_s", 1},
                               {"parity", "X"}, {"speed", 9600}});
    FAIL() << "no FieldError";
  } catch (const description::FieldError& e) {
    EXPECT_THAT(e.lines(), UnorderedElementsAre(HasSubstr("/port: must be an integer in [1, 65535]"),
                                                   HasSubstr("/parity: must be one of E, N, O"),
                                                   HasSubstr("/device: the serial device is required"),
                                                   HasSubstr("/heartbeat_s: must be shorter"),
                                                   HasSubstr("/speed: unknown key")));
  }
}

TEST(ModbusCmm, ConnectGivesUpWithCommLostAfterItsBackoff) {
  ModbusCmm cmm;
  // Port 1 on loopback: nothing listens, every attempt is refused at once.
  cmm.configure({{"port", 1}, {"connect_attempts", 3}, {"connect_backoff_s", 0.02}});
  const auto t0 = std::chrono::steady_clock::now();
  try {
    cmm.connect();
    FAIL() << "connected to nothing";
  } catch (const CommLost& e) {
    EXPECT_THAT(e.what(), HasSubstr("127.0.0.1:1 after 3 attempts"));
  }
  const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_GE(waited, 0.02 + 0.04);  // the backoff doubled between attempts
  EXPECT_LT(waited, 2.0);
  EXPECT_THROW(cmm.status(), StateError);
  EXPECT_THROW(cmm.enable(), StateError);
}

}  // namespace
}  // namespace cmm::hal
