"""CANopen slaves nobody here wrote, for coe-core's master (tests/tests/system_can_master_python.rs).

Each slave is its own socketcand connection to the virtual bus on CAN_PORT (so each is a
node of its own in arbitration):
- DURAND node-IDs (comma-separated): durand's Node (PyPI durand, a pure-Python CANopen slave);
- LOCAL node-ID: python-canopen's LocalNode, with the glue it lacks (boot-up after an NMT
  reset, TPDOs on SYNC, RPDOs into its data store; its own SDO server and heartbeat run
  as they are).

Every slave has 8 input bytes at 0x2000 and 8 output bytes at 0x2100; its application
copies each output byte plus one into the input byte of the same subindex, so what the
master writes comes back changed through the slave's own PDOs. Identity: device type
0x000F0191, vendor 0x0000ABCD, product 0x1000 + node-ID, revision 1, serial node-ID.

Commands on stdin, one per line: KILL n (the slave's connection closes), REVIVE n (a new
slave with that node-ID connects, it boots up), EMCY n (durand: an Emergency 0x1000),
DUMP n (prints "PDO n index:sub=value" for its PDO parameters), QUIT. Lines on stdout:
READY, DUMPED n, and what each command did.
"""

import logging
import os
import struct
import sys
import threading
import time

import can
import canopen
import durand
from canopen.objectdictionary import ODArray, ODRecord, ODVariable
from durand import CANBusNetwork, Node, Variable, Record, Array, DatatypeEnum as DT

PORT = int(os.environ["CAN_PORT"])
DURAND = [int(n) for n in os.environ.get("DURAND", "").split(",") if n]
LOCAL = int(os.environ.get("LOCAL", "0"))

DEVICE_TYPE = 0x000F0191
VENDOR = 0x0000ABCD

# python-can's socketcand interface logs every remote frame (node guarding of the
# firmware's node) as unparseable: it carries none.
logging.getLogger("can").setLevel(logging.ERROR)

SCHEDULER = durand.scheduler.SyncScheduler()
durand.set_scheduler(SCHEDULER)


def run_scheduler():
    # One scheduler serves every durand node: a timer of a node whose connection just
    # closed must not stop the others' heartbeats.
    while not SCHEDULER._stop:
        try:
            SCHEDULER.run()
        except Exception as e:  # noqa: BLE001
            print(f"durand timer failed: {e!r}", file=sys.stderr, flush=True)


threading.Thread(target=run_scheduler, daemon=True).start()


def bus():
    return can.Bus(interface="socketcand", host="127.0.0.1", port=PORT, channel="can0")


def say(line):
    print(line, flush=True)


# ---------------------------------------------------------------------------- durand


class DurandSlave:
    def __init__(self, node_id):
        self.id = node_id
        self.bus = bus()
        self.network = CANBusNetwork(self.bus)
        od = durand.object_dictionary.ObjectDictionary()
        self.node = Node(self.network, node_id, od)
        od.write(0x1000, 0, DEVICE_TYPE)
        for sub, value in ((1, VENDOR), (2, 0x1000 + node_id), (3, 1), (4, node_id)):
            od.write(0x1018, sub, value)
        od[0x2000] = Array(Variable(DT.UNSIGNED8, "ro", 0), length=8, name="Inputs")
        od[0x2100] = Array(Variable(DT.UNSIGNED8, "rw", 0), length=8, name="Outputs")
        for sub in range(1, 9):
            od.update_callbacks[(0x2100, sub)].add(
                lambda value, sub=sub: od.write(0x2000, sub, (value + 1) & 0xFF))

    def read(self, index, sub):
        return self.node.object_dictionary.read(index, sub)

    def emergency(self):
        self.node.emcy.set(0x1000, 1, b"\x11\x22")

    def close(self):
        # Its heartbeat timer goes first (it would send on the closed connection).
        self.node.object_dictionary.write(0x1017, 0, 0)
        self.network.stop()
        self.bus.shutdown()


# ---------------------------------------------------------------------------- python-canopen


def variable(name, index, sub, data_type, access, default):
    v = ODVariable(name, index, sub)
    v.data_type = data_type
    v.access_type = access
    v.default = default
    return v


def local_dictionary(node_id):
    U8, U16, U32 = canopen.objectdictionary.UNSIGNED8, canopen.objectdictionary.UNSIGNED16, \
        canopen.objectdictionary.UNSIGNED32
    od = canopen.ObjectDictionary()
    od.add_object(variable("Device type", 0x1000, 0, U32, "ro", DEVICE_TYPE))
    od.add_object(variable("Producer heartbeat time", 0x1017, 0, U16, "rw", 0))
    identity = ODRecord("Identity", 0x1018)
    identity.add_member(variable("Highest sub-index", 0x1018, 0, U8, "const", 4))
    for sub, value in ((1, VENDOR), (2, 0x1000 + node_id), (3, 1), (4, node_id)):
        identity.add_member(variable(f"Identity {sub}", 0x1018, sub, U32, "ro", value))
    od.add_object(identity)
    for i in range(4):
        for comm, mapping, base in ((0x1400, 0x1600, 0x200), (0x1800, 0x1A00, 0x180)):
            rec = ODRecord(f"PDO comm {comm + i:X}", comm + i)
            rec.add_member(variable("Highest sub-index", comm + i, 0, U8, "const", 5))
            cob = 0x80000000 | (base + 0x100 * i + node_id)
            rec.add_member(variable("COB-ID", comm + i, 1, U32, "rw", cob))
            rec.add_member(variable("Transmission type", comm + i, 2, U8, "rw", 255))
            rec.add_member(variable("Inhibit time", comm + i, 3, U16, "rw", 0))
            rec.add_member(variable("Event timer", comm + i, 5, U16, "rw", 0))
            od.add_object(rec)
            m = ODRecord(f"PDO mapping {mapping + i:X}", mapping + i)
            m.add_member(variable("Number of entries", mapping + i, 0, U8, "rw", 0))
            for sub in range(1, 9):
                m.add_member(variable(f"Entry {sub}", mapping + i, sub, U32, "rw", 0))
            od.add_object(m)
    for index, name, access in ((0x2000, "Inputs", "ro"), (0x2100, "Outputs", "rw")):
        arr = ODArray(name, index)
        arr.add_member(variable("Highest sub-index", index, 0, U8, "const", 8))
        for sub in range(1, 9):
            arr.add_member(variable(f"{name} {sub}", index, sub, U8, access, 0))
        od.add_object(arr)
    return od


class LocalSlave:
    """python-canopen's LocalNode with the glue a CANopen slave needs."""

    def __init__(self, node_id):
        self.id = node_id
        self.network = canopen.Network()
        self.network.connect(interface="socketcand", host="127.0.0.1", port=PORT,
                             channel="can0")
        self.node = canopen.LocalNode(node_id, local_dictionary(node_id))
        self.network.add_node(self.node)
        self.network.subscribe(0x000, self.on_nmt)
        self.network.subscribe(0x080, self.on_sync)
        for base in (0x200, 0x300, 0x400, 0x500):
            self.network.subscribe(base + node_id, self.on_rpdo)
        self.boot_up()

    def boot_up(self):
        # LocalNode stays in INITIALISING after a reset and sends no boot-up itself.
        nmt = self.node.nmt
        nmt.send_command(0x82)       # state 0: the boot-up message goes out
        nmt.send_command(0x80)       # pre-operational; the heartbeat starts from 0x1017

    def on_nmt(self, can_id, data, timestamp):
        if len(data) == 2 and data[1] in (0, self.id) and data[0] in (0x81, 0x82):
            self.boot_up()

    def get(self, index, sub):
        return self.node.get_data(index, sub)

    def value(self, index, sub):
        return int.from_bytes(self.get(index, sub), "little")

    def read(self, index, sub):
        return self.value(index, sub)

    def pdo(self, comm, mapping, i):
        cob = self.value(comm + i, 1)
        if cob & 0x80000000:
            return None
        entries = [self.value(mapping + i, s) for s in range(1, self.value(mapping + i, 0) + 1)]
        return cob & 0x7FF, entries

    def on_sync(self, can_id, data, timestamp):
        if self.node.nmt.state != "OPERATIONAL":
            return
        for i in range(4):
            pdo = self.pdo(0x1800, 0x1A00, i)
            if pdo is None:
                continue
            cob, entries = pdo
            payload = b"".join(self.get(e >> 16, (e >> 8) & 0xFF) for e in entries)
            self.network.send_message(cob, payload)

    def on_rpdo(self, can_id, data, timestamp):
        if self.node.nmt.state != "OPERATIONAL":
            return
        for i in range(4):
            pdo = self.pdo(0x1400, 0x1600, i)
            if pdo is None or pdo[0] != can_id:
                continue
            at = 0
            for e in pdo[1]:
                n = (e & 0xFF) // 8
                index, sub = e >> 16, (e >> 8) & 0xFF
                self.node.set_data(index, sub, bytes(data[at:at + n]))
                if index == 0x2100:
                    self.node.set_data(0x2000, sub, bytes([(data[at] + 1) & 0xFF]))
                at += n

    def emergency(self):
        self.node.emcy.send(0x1000, 1, b"\x11\x22")

    def close(self):
        self.node.nmt.stop_heartbeat()
        self.network.disconnect()


# ---------------------------------------------------------------------------- main


def make(node_id):
    return LocalSlave(node_id) if node_id == LOCAL else DurandSlave(node_id)


def main():
    slaves = {n: make(n) for n in DURAND + ([LOCAL] if LOCAL else [])}
    say("READY")
    for line in sys.stdin:
        words = line.split()
        if not words:
            continue
        cmd, args = words[0], [int(w) for w in words[1:]]
        if cmd == "QUIT":
            break
        n = args[0]
        if cmd == "KILL":
            slaves.pop(n).close()
            say(f"KILLED {n}")
        elif cmd == "REVIVE":
            slaves[n] = make(n)
            say(f"REVIVED {n}")
        elif cmd == "EMCY":
            slaves[n].emergency()
            say(f"EMCY {n}")
        elif cmd == "DUMP":
            s = slaves[n]
            for comm, mapping in ((0x1400, 0x1600), (0x1800, 0x1A00)):
                for i in range(4):
                    for index, sub in ((comm + i, 1), (comm + i, 2), (mapping + i, 0)):
                        say(f"PDO {n} {index:04X}:{sub}={s.read(index, sub):#x}")
                    count = s.read(mapping + i, 0)
                    for sub in range(1, count + 1):
                        say(f"PDO {n} {mapping + i:04X}:{sub}={s.read(mapping + i, sub):#x}")
            say(f"DUMPED {n}")
    for s in slaves.values():
        s.close()
    SCHEDULER.stop()


if __name__ == "__main__":
    main()
