// Port listing through libserialport's enumeration.
#include "hal/serial_ports.hpp"

#include <libserialport.h>

#include <cstdio>
#include <memory>
#include <stdexcept>

namespace cmm::hal {

namespace {
std::string text(const char* s) { return s ? s : ""; }
}  // namespace

std::vector<SerialPortInfo> list_serial_ports() {
  sp_port** ports = nullptr;
  if (sp_list_ports(&ports) != SP_OK) {
    char* message = sp_last_error_message();
    std::string why = text(message);
    sp_free_error_message(message);
    throw std::runtime_error("cannot list serial ports: " + why);
  }
  std::unique_ptr<sp_port*, void (*)(sp_port**)> owner(ports, sp_free_port_list);
  std::vector<SerialPortInfo> out;
  for (sp_port** p = ports; *p; ++p) {
    SerialPortInfo info;
    info.name = text(sp_get_port_name(*p));
    info.description = text(sp_get_port_description(*p));
    switch (sp_get_port_transport(*p)) {
      case SP_TRANSPORT_USB: {
        info.transport = "usb";
        int vid = 0, pid = 0;
        if (sp_get_port_usb_vid_pid(*p, &vid, &pid) == SP_OK) info.usb_vid = vid, info.usb_pid = pid;
        info.usb_manufacturer = text(sp_get_port_usb_manufacturer(*p));
        info.usb_product = text(sp_get_port_usb_product(*p));
        info.usb_serial = text(sp_get_port_usb_serial(*p));
        break;
      }
      case SP_TRANSPORT_BLUETOOTH: info.transport = "bluetooth"; break;
      default: info.transport = "native"; break;
    }
    out.push_back(info);
  }
  return out;
}

std::string describe(const SerialPortInfo& port) {
  std::string line = port.name + "  " + port.transport;
  if (port.usb_vid && port.usb_pid) {
    char ids[16];
    std::snprintf(ids, sizeof ids, " %04x:%04x", *port.usb_vid & 0xffff, *port.usb_pid & 0xffff);
    line += ids;
  }
  if (!port.description.empty()) line += "  " + port.description;
  std::string extra;
  if (!port.usb_manufacturer.empty()) extra += port.usb_manufacturer;
  if (!port.usb_serial.empty()) extra += (extra.empty() ? "" : ", ") + std::string("serial ") + port.usb_serial;
  if (!extra.empty()) line += " (" + extra + ")";
  return line;
}

}  // namespace cmm::hal
