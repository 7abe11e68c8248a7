// Serial port listing: whatever this machine has is listed without error, and a USB port's line
// shows its ids the way lsusb does.
#include "hal/serial_ports.hpp"

#include <gtest/gtest.h>

namespace cmm::hal {
namespace {

TEST(SerialPorts, ListsWhatTheMachineHas) {
  for (const SerialPortInfo& port : list_serial_ports()) {
    EXPECT_FALSE(port.name.empty());
    EXPECT_TRUE(port.transport == "usb" || port.transport == "native" || port.transport == "bluetooth") << port.name;
    EXPECT_EQ(port.usb_vid.has_value(), port.usb_pid.has_value()) << port.name;
  }
}

TEST(SerialPorts, DescribesAUsbPortWithItsIds) {
  SerialPortInfo uno{"/dev/ttyACM0", "Arduino Uno", "usb", 0x2341, 0x0043, "Arduino LLC", "Uno", "75237333536351F0C1C1"};
  EXPECT_EQ(describe(uno), "/dev/ttyACM0  usb 2341:0043  Arduino Uno (Arduino LLC, serial 75237333536351F0C1C1)");
  SerialPortInfo native{"/dev/ttyS0", "", "native", std::nullopt, std::nullopt, "", "", ""};
  EXPECT_EQ(describe(native), "/dev/ttyS0  native");
}

}  // namespace
}  // namespace cmm::hal
