#!/usr/bin/env python3
"""SOEM through pysoem as an independent master of the module on a network interface.

    python3 pysoem_master.py IFACE [CYCLES]

PRE-OP (SOEM reads the SII), SDO uploads of the identity (0x1000, 0x1008, 0x1018:01..04),
the process-data mapping (config_map), SAFE-OP, OP, then CYCLES process-data exchanges: the
master writes a new AO pair every cycle and reads the AI values back. One JSON object per
line on stdout: {"step": ..., ...}; the last line is {"step": "done", "ok": true|false}.
The exit code is 0 only when every step worked.
"""

import argparse
import json
import struct
import sys
import time

import pysoem


def say(**kv):
    print(json.dumps(kv), flush=True)


def wait_state(master, slave, state, timeout_us):
    """Requests `state` and waits for it (SOEM's state_check, repeated)."""
    slave.state = state
    slave.write_state()
    deadline = time.monotonic() + timeout_us / 1e6
    while time.monotonic() < deadline:
        if slave.state_check(state, 50_000) == state:
            return True
    master.read_state()
    return slave.state == state


def main():
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("iface", help="the network interface the module is on")
    parser.add_argument(
        "cycles", nargs="?", type=int, default=200, help="process-data exchanges in OP"
    )
    args = parser.parse_args()
    iface, cycles = args.iface, args.cycles
    # SOEM waits 2 ms for a datagram by default; the co-simulated image answers from a
    # user-space thread, slower than real time on a loaded host. A real module answers in
    # microseconds, so the longer waits cost nothing there.
    timeouts = pysoem.settings.timeouts
    timeouts.ret = max(timeouts.ret, 50_000)
    timeouts.safe = max(timeouts.safe, 200_000)
    timeouts.eeprom = max(timeouts.eeprom, 200_000)
    master = pysoem.Master()
    master.open(iface)
    try:
        n = master.config_init()
        say(step="config_init", slaves=n)
        if n != 1:
            return False
        slave = master.slaves[0]
        say(
            step="sii",
            name=slave.name,
            vendor=slave.man,
            product=slave.id,
            revision=slave.rev,
        )
        master.read_state()
        say(step="state", state=slave.state, al_status_code=slave.al_status)
        if slave.state != pysoem.PREOP_STATE:
            return False
        device_type = struct.unpack("<I", slave.sdo_read(0x1000, 0))[0]
        name = slave.sdo_read(0x1008, 0).decode("ascii", "replace")
        identity = [struct.unpack("<I", slave.sdo_read(0x1018, s))[0] for s in range(1, 5)]
        say(step="sdo", device_type=device_type, name=name, identity=identity)
        size = master.config_map()
        say(step="config_map", bytes=size, outputs=len(slave.output), inputs=len(slave.input))
        if not wait_state(master, slave, pysoem.SAFEOP_STATE, 5_000_000):
            say(step="safeop", ok=False, state=slave.state, al_status_code=slave.al_status)
            return False
        say(step="safeop", ok=True)
        # OP needs valid outputs flowing (SM watchdog): send before and while asking.
        slave.output = struct.pack("<hh", 0, 0)
        master.send_processdata()
        master.receive_processdata(20_000)
        slave.state = pysoem.OP_STATE
        slave.write_state()
        in_op = False
        deadline = time.monotonic() + 5.0
        while time.monotonic() < deadline and not in_op:
            master.send_processdata()
            master.receive_processdata(20_000)
            in_op = slave.state_check(pysoem.OP_STATE, 1_000) == pysoem.OP_STATE
        say(step="op", ok=in_op, state=slave.state, al_status_code=slave.al_status)
        if not in_op:
            return False
        good = 0
        ai = []
        for i in range(cycles):
            ao1, ao2 = (i * 97) % 0x7FFF, 0x7FFF - (i * 89) % 0x7FFF
            slave.output = struct.pack("<hh", ao1, ao2)
            master.send_processdata()
            wkc = master.receive_processdata(20_000)
            if wkc == master.expected_wkc:
                good += 1
            ai = list(struct.unpack("<8h", bytes(slave.input[:16])))
            time.sleep(0.001)
        master.read_state()
        say(
            step="process_data",
            cycles=cycles,
            good_wkc=good,
            last_outputs=[ao1, ao2],
            ai=ai,
            state=slave.state,
        )
        ok = good == cycles and slave.state == pysoem.OP_STATE
        wait_state(master, slave, pysoem.INIT_STATE, 5_000_000)
        say(step="init", state=slave.state)
        return ok
    finally:
        master.close()


if __name__ == "__main__":
    try:
        ok = main()
    except Exception as e:  # a SOEM error is a failed step, reported as such
        say(step="error", error=repr(e))
        ok = False
    say(step="done", ok=bool(ok))
    sys.exit(0 if ok else 1)
