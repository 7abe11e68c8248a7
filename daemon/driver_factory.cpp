// The list of drivers: a name, the name it stands for, and how to make one.
#include "daemon/driver_factory.hpp"

#include <functional>
#include <stdexcept>
#include <vector>

#include "hal/grbl_cmm.hpp"
#include "hal/ippdme_cmm.hpp"
#include "hal/modbus_cmm.hpp"
#include "sim/simulated_cmm.hpp"

namespace cmm::daemon {

namespace {

struct Driver {
  std::string name;
  std::string is;  // the driver an alias stands for; its own name otherwise
  std::function<std::unique_ptr<hal::Cmm>(const std::string& base_dir)> make;
};

const std::vector<Driver>& drivers() {
  static const std::vector<Driver> list = {
      {"sim", "sim", [](const std::string& dir) { return std::make_unique<sim::SimulatedCmm>(dir); }},
      {"modbus", "modbus", [](const std::string&) { return std::make_unique<hal::ModbusCmm>(); }},
      {"grbl", "grbl", [](const std::string& dir) { return std::make_unique<hal::GrblCmm>(dir); }},
      {"serial", "grbl", [](const std::string& dir) { return std::make_unique<hal::GrblCmm>(dir); }},
      {"ippdme", "ippdme", [](const std::string& dir) { return std::make_unique<hal::IppDmeCmm>(dir); }},
  };
  return list;
}

const Driver& find(const std::string& name) {
  for (const Driver& d : drivers())
    if (d.name == name) return d;
  std::string known;
  for (const Driver& d : drivers()) known += (known.empty() ? "" : ", ") + d.name;
  throw std::invalid_argument("unknown machine driver \"" + name + "\" (known: " + known + ")");
}

}  // namespace

const char* default_driver_name() { return "sim"; }

const std::set<std::string>& driver_names() {
  static const std::set<std::string> names = [] {
    std::set<std::string> out;
    for (const Driver& d : drivers()) out.insert(d.name);
    return out;
  }();
  return names;
}

std::string canonical_driver_name(const std::string& name) { return find(name).is; }

std::unique_ptr<hal::Cmm> make_driver(const std::string& name, const std::string& base_dir) {
  return find(name).make(base_dir);
}

std::unique_ptr<hal::Cmm> make_simulator(const std::string& base_dir) { return make_driver("sim", base_dir); }

}  // namespace cmm::daemon
