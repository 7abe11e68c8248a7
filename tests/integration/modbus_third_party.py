"""A third-party Modbus client (pymodbus) homes cmm-sim and touches its part once, knowing only
docs/modbus-map.md: every address, size and opcode below is read from that page, none is typed in.
Run with Debian's /usr/bin/python3 (pymodbus): modbus_third_party.py --port P --doc docs/modbus-map.md"""
import argparse
import json
import re
import sys
import time

from pymodbus.client import ModbusTcpClient


def read_map(path):
    registers = {}
    for line in open(path, encoding="utf-8"):
        m = re.match(r"\|\s*(\d+)\s*\|\s*(\d+)\s*\|\s*`(\w+)`\s*\|\s*(\w+)\s*\|", line)
        if m:
            registers[m.group(3)] = (int(m.group(1)), int(m.group(2)), m.group(4))
    opcodes = {}
    for line in open(path, encoding="utf-8"):
        if "`opcode`" in line:
            opcodes = {name: int(n) for n, name in re.findall(r"(\d+) (home|move|probe)", line)}
    return registers, opcodes


class Machine:
    def __init__(self, port, registers, opcodes):
        self.client = ModbusTcpClient("127.0.0.1", port=port)
        if not self.client.connect():
            sys.exit("cannot connect to cmm-sim on port %d" % port)
        self.r, self.ops = registers, opcodes
        self.first = registers["seq"][0]
        # The command block: the registers that follow `seq` without a gap (400–424 in the page).
        end = self.first
        for address, count, _ in sorted(registers.values()):
            if address == end:
                end += count
        self.size = end - self.first
        self.seq = self.read("done_seq")

    def regs(self, address, count):
        try:
            reply = self.client.read_holding_registers(address, count, slave=1)
        except TypeError:  # pymodbus before 3.0 called it unit
            reply = self.client.read_holding_registers(address, count, unit=1)
        if reply.isError():
            sys.exit("read of %d failed: %s" % (address, reply))
        return reply.registers

    def read(self, name):
        address, count, kind = self.r[name]
        words = self.regs(address, count)
        if kind == "u16":
            return words[0]
        value = (words[0] << 16) | words[1]  # high word first
        return value - (1 << 32) if kind == "i32" and value >= 1 << 31 else value

    def command(self, opcode, **fields):
        block = [0] * self.size
        self.seq = self.seq % 65535 + 1
        fields.update(seq=self.seq, opcode=self.ops[opcode])
        for name, value in fields.items():
            address, count, kind = self.r[name]
            at = address - self.first
            if count == 1:
                block[at] = value
            else:
                value &= 0xFFFFFFFF
                block[at], block[at + 1] = value >> 16, value & 0xFFFF
        reply = self.client.write_registers(self.first, block, slave=1)
        if reply.isError():
            sys.exit("write of the command block failed: %s" % reply)
        deadline = time.time() + 30
        while self.read("done_seq") != self.seq:
            if time.time() > deadline:
                sys.exit("no echo of command %d" % self.seq)
        result = self.read("done_result")
        if result:
            sys.exit("%s failed with fault code %d" % (opcode, result))


def nm(mm):
    return int(round(mm * 1e6))


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--port", type=int, required=True)
    parser.add_argument("--doc", required=True)
    parser.add_argument("--x", type=float, required=True)
    parser.add_argument("--y", type=float, required=True)
    parser.add_argument("--z", type=float, required=True)
    args = parser.parse_args()
    registers, opcodes = read_map(args.doc)
    machine = Machine(args.port, registers, opcodes)
    machine.command("home")
    machine.command("move", x=nm(args.x), y=nm(args.y), z=nm(60))
    machine.command("probe", x=nm(args.x), y=nm(args.y), z=nm(args.z), dir_z=-10**9, speed=5000,
                    max_travel=nm(10), min_travel=nm(2), retract=nm(2), probe_flags=1)
    touch = [machine.read(k) * 1e-6 for k in ("touch_x", "touch_y", "touch_z")]
    print(json.dumps({"contact": machine.read("touch_contact"), "touch_mm": touch,
                      "homed": bool(machine.read("flags") & 1)}))


if __name__ == "__main__":
    main()
