// The serial ports this machine has, with their USB identity, so an operator (cmmctl ports) can
// tell the CMM's controller from a modem without unplugging cables. Listing uses libserialport.
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace cmm::hal {

struct SerialPortInfo {
  std::string name;         // e.g. /dev/ttyACM0
  std::string description;  // libserialport's, e.g. "Arduino Uno"
  std::string transport;    // native | usb | bluetooth
  std::optional<int> usb_vid, usb_pid;
  std::string usb_manufacturer, usb_product, usb_serial;
};

// Every port the OS lists (ptys are not ports to libserialport 0.1.1 and do not appear). Throws
// std::runtime_error with libserialport's message when it cannot enumerate.
std::vector<SerialPortInfo> list_serial_ports();

// "/dev/ttyACM0  usb 2341:0043  Arduino Uno (Arduino LLC, serial 7523…)": one line for a listing.
std::string describe(const SerialPortInfo& port);

}  // namespace cmm::hal
