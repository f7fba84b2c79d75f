"""python-canopen as the CANopen master of the virtual board (tests/tests/system_canopen.rs).

The board is served through socketcand (python-can's ``socketcand`` interface, channel
``can0``) on CAN_PORT; NODE_ID is the module's node-ID, EDS the module's EDS (generated
from the same description as the ESI), AI_VOLTS the voltages on AI2..AI8 and SINE the
loop-back sine on AI1 ("offset,amplitude,hz"). Lines the Rust side reads:
``RPDO AO a,b`` and ``FAULT AO a`` (values it must find on the DAC) and
``LOOPBACK t0 t1 sync_ms`` (the loop-back window in bus time).
"""

import logging
import os
import sys
import threading
import time
import unittest
import warnings

import canopen
from canopen.sdo.exceptions import SdoAbortedError

PORT = int(os.environ["CAN_PORT"])
NODE_ID = int(os.environ["NODE_ID"])
EDS = os.environ["EDS"]
AI_VOLTS = [float(v) for v in os.environ["AI_VOLTS"].split(",")]
SINE_OFFSET, SINE_AMPLITUDE, SINE_HZ = (float(v) for v in os.environ["SINE"].split(","))

# 0x6401: 0x7FFF = 10 V (product documentation, 0x2001).
FULL_SCALE = 0x7FFF


def ai_value(volts):
    return round(volts / 10.0 * FULL_SCALE)


class Log(logging.Handler):
    """Every log record of canopen and can at WARNING or above."""

    def __init__(self):
        super().__init__(logging.WARNING)
        self.records = []

    def emit(self, record):
        self.records.append(record)


LOG = Log()
logging.getLogger("canopen").addHandler(LOG)
logging.getLogger("can").addHandler(LOG)


class Master(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            cls.od = canopen.import_od(EDS, node_id=NODE_ID)
        cls.eds_warnings = [str(w.message) for w in caught] + [
            r.getMessage() for r in LOG.records
        ]
        cls.network = canopen.Network()
        cls.network.connect(
            interface="socketcand", host="127.0.0.1", port=PORT, channel="can0"
        )
        cls.node = cls.network.add_node(NODE_ID, cls.od)
        cls.node.sdo.RESPONSE_TIMEOUT = 1.0
        cls.frames = []
        cls.network.subscribe(0x700 + NODE_ID, cls._heartbeat)

    @classmethod
    def tearDownClass(cls):
        cls.network.sync.stop()
        cls.network.disconnect()

    @classmethod
    def _heartbeat(cls, can_id, data, timestamp):
        cls.frames.append((timestamp, bytes(data)))

    def abort_code(self, fn):
        with self.assertRaises(SdoAbortedError) as ctx:
            fn()
        return ctx.exception.code

    def up(self, index, sub=0, signed=False):
        return int.from_bytes(self.node.sdo.upload(index, sub), "little", signed=signed)

    def reset_node(self):
        self.node.nmt.send_command(0x81)
        self.node.nmt.wait_for_bootup(5)

    # ------------------------------------------------------------------ tests

    def test_01_boot_up(self):
        self.reset_node()
        self.assertEqual(self.node.nmt.state, "PRE-OPERATIONAL")

    def test_02_eds_imports_and_matches_the_device(self):
        self.assertEqual(self.eds_warnings, [], "python-canopen's EDS reader warned")
        self.reset_node()
        live = {0x1001, 0x1003, 0x6401, 0x6411}  # the errors and the I/O change
        errors = self.up(0x1003)
        checked = 0
        for index in self.od:
            if index < 0x1000:
                continue  # the dummy types of [DummyUsage], not objects
            obj = self.od[index]
            variables = [obj] if isinstance(obj, canopen.objectdictionary.ODVariable) else [
                obj[s] for s in obj.subindices
            ]
            for var in variables:
                if var.index == 0x1003 and var.subindex > errors:
                    # No error there: CiA 301's "no data available".
                    self.assertEqual(self.abort_code(
                        lambda: self.node.sdo.upload(0x1003, var.subindex)), 0x08000024)
                    continue
                raw = self.node.sdo.upload(var.index, var.subindex)
                if var.data_type not in (0x09, 0x0A, 0x0F):
                    size = {1: 1, 2: 1, 3: 2, 4: 4, 5: 1, 6: 2, 7: 4}.get(var.data_type)
                    self.assertEqual(len(raw), size, f"{var.index:#x}:{var.subindex}")
                if var.default is None or var.index in live:
                    continue
                value = var.decode_raw(raw)
                self.assertEqual(value, var.default, f"{var.index:#x}:{var.subindex} {var.name}")
                checked += 1
        print(f"EDS: {checked} defaults equal what the device answers")
        self.assertGreater(checked, 100)
        # The PDO configuration as the EDS says (CiA 401 analog PDOs).
        self.node.tpdo.read()
        self.node.rpdo.read()
        self.assertEqual([v.index for v in self.node.tpdo[2].map], [0x6401] * 4)
        self.assertEqual([v.subindex for v in self.node.tpdo[3].map], [5, 6, 7, 8])
        self.assertEqual([(v.index, v.subindex) for v in self.node.rpdo[2].map],
                         [(0x6411, 1), (0x6411, 2)])
        self.assertTrue(self.node.tpdo[2].enabled and not self.node.tpdo[1].enabled)

    def test_03_sdo_expedited_segmented_and_aborts(self):
        self.assertEqual(self.up(0x1000), 0x000C0191)
        self.assertEqual(self.up(0x1018, 2), self.od[0x1018][2].default)
        # Segmented uploads: 7-byte segments on CAN.
        self.assertEqual(self.node.sdo.upload(0x1008, 0).decode(), self.od[0x1008].default)
        description = self.node.sdo.upload(0x2001, 0).decode()
        self.assertEqual(description, self.od[0x2001].default)
        self.assertGreater(len(description), 100)
        # Expedited and segmented downloads.
        self.node.sdo.download(0x6444, 1, (1000).to_bytes(4, "little"))
        self.assertEqual(self.up(0x6444, 1), 1000)
        self.node.sdo.download(0x1017, 0, (250).to_bytes(2, "little"), force_segment=True)
        self.assertEqual(self.up(0x1017), 250)
        self.node.sdo.download(0x1017, 0, (0).to_bytes(2, "little"))
        # The aborts.
        codes = {
            "read-only": self.abort_code(lambda: self.node.sdo.download(0x1000, 0, b"\0\0\0\0")),
            "no object": self.abort_code(lambda: self.node.sdo.upload(0x1234, 0)),
            "no subindex": self.abort_code(lambda: self.node.sdo.upload(0x6401, 9)),
            "too high": self.abort_code(
                lambda: self.node.sdo.download(0x6444, 1, (40000).to_bytes(4, "little"))),
            "too long": self.abort_code(lambda: self.node.sdo.download(0x1017, 0, b"\1\2\3")),
            "too short": self.abort_code(lambda: self.node.sdo.download(0x1014, 0, b"\1")),
        }
        self.assertEqual(codes, {
            "read-only": 0x06010002,
            "no object": 0x06020000,
            "no subindex": 0x06090011,
            "too high": 0x06090031,
            "too long": 0x06070012,
            "too short": 0x06070013,
        })

    def test_04_nmt_and_heartbeat_timing(self):
        self.node.sdo.download(0x1017, 0, (100).to_bytes(2, "little"))
        type(self).frames = []
        time.sleep(1.05)
        beats = list(type(self).frames)
        self.assertGreaterEqual(len(beats), 9, beats)
        self.assertTrue(all(d == b"\x7f" for _, d in beats), beats)
        gaps = [b[0] - a[0] for a, b in zip(beats, beats[1:])]
        # Bus time: the node's timer on the board's clock, exact to the bus tick.
        for g in gaps:
            self.assertAlmostEqual(g, 0.100, delta=0.0015)
        print(f"heartbeat: {len(gaps)} gaps of {min(gaps) * 1e3:.3f}..{max(gaps) * 1e3:.3f} ms")
        for command, code in (("OPERATIONAL", 5), ("STOPPED", 4), ("PRE-OPERATIONAL", 127)):
            type(self).frames = []
            self.node.nmt.state = command
            time.sleep(0.15)
            self.assertEqual(type(self).frames[0][1], bytes([code]), command)
        # Stopped: no SDO answer.
        self.node.nmt.state = "STOPPED"
        time.sleep(0.05)
        with self.assertRaises(canopen.SdoCommunicationError):
            self.node.sdo.upload(0x1000, 0)
        # Reset communication: boot-up, heartbeat back to its default (0).
        self.node.nmt.send_command(0x82)
        self.node.nmt.wait_for_bootup(5)
        self.assertEqual(self.up(0x1017), 0)

    def test_05_pdo_remapping_in_pre_operational(self):
        self.node.tpdo.read()
        tpdo = self.node.tpdo[2]
        tpdo.clear()
        tpdo.add_variable(0x6401, 8)
        tpdo.add_variable(0x6401, 2)
        tpdo.trans_type = 1
        tpdo.enabled = True
        tpdo.save()
        self.assertEqual(self.up(0x1A01, 0), 2)
        self.assertEqual(self.up(0x1A01, 1), 0x64010810)
        # Not in operational (0x08000022), and an output cannot go into a TPDO.
        self.node.nmt.state = "OPERATIONAL"
        time.sleep(0.05)
        self.assertEqual(self.abort_code(lambda: self.node.sdo.download(0x1A01, 0, b"\0")),
                         0x08000022)
        self.node.nmt.state = "PRE-OPERATIONAL"
        time.sleep(0.05)
        self.node.sdo.download(0x1801, 1, (0x80000000 | 0x280 + NODE_ID).to_bytes(4, "little"))
        self.node.sdo.download(0x1A01, 0, b"\0")
        self.assertEqual(
            self.abort_code(lambda: self.node.sdo.download(0x1A01, 1, (0x64110110).to_bytes(4, "little"))),
            0x06040041)
        # Back to the CiA 401 default.
        self.reset_node()

    def test_06_sync_driven_tpdos_carry_the_inputs(self):
        self.node.tpdo.read()
        for n in (2, 3):
            self.node.tpdo[n].trans_type = 1
            self.node.tpdo[n].save()
        self.node.nmt.state = "OPERATIONAL"
        time.sleep(0.05)
        for _ in range(3):
            self.network.sync.transmit()
            self.node.tpdo[3].wait_for_reception(1)
            time.sleep(0.02)
        ai = [v.raw for v in self.node.tpdo[2].map] + [v.raw for v in self.node.tpdo[3].map]
        print("TPDO AI", ai)
        for got, volts in zip(ai[1:], AI_VOLTS):
            self.assertAlmostEqual(got, ai_value(volts), delta=20)
        self.assertTrue(ai_value(SINE_OFFSET - SINE_AMPLITUDE) - 20 <= ai[0]
                        <= ai_value(SINE_OFFSET + SINE_AMPLITUDE) + 20)
        self.node.nmt.state = "PRE-OPERATIONAL"

    def test_07_rpdos_drive_the_outputs(self):
        self.node.rpdo.read()
        # EtherCAT drives the outputs by default: CAN takes them (0x2002 = 1).
        self.node.sdo.download(0x2002, 0, b"\1")
        self.node.nmt.state = "OPERATIONAL"
        time.sleep(0.05)
        # Switching the source while operational is refused.
        self.assertEqual(self.abort_code(lambda: self.node.sdo.download(0x2002, 0, b"\0")),
                         0x08000022)
        for a, b in ((0x4000, 0x2000), (0x1234, 0x7FFF)):
            self.node.rpdo[2][0].raw = a
            self.node.rpdo[2][1].raw = b
            self.node.rpdo[2].transmit()
            time.sleep(0.05)
            self.assertEqual(self.up(0x6411, 1, signed=True), a)
            print(f"RPDO AO {a},{b}")

    def test_08_loopback_ai1_to_ao1(self):
        # TPDO 2 every SYNC; the master copies AI1 into RPDO 2 (AO1) as it arrives.
        self.node.nmt.state = "PRE-OPERATIONAL"
        time.sleep(0.05)
        self.node.tpdo.read()
        self.node.tpdo[2].trans_type = 1
        self.node.tpdo[2].save()
        self.node.nmt.state = "OPERATIONAL"
        rpdo = self.node.rpdo[2]
        times = []

        def copy(tpdo):
            rpdo[0].raw = tpdo[0].raw
            rpdo[1].raw = 0
            rpdo.transmit()
            times.append(tpdo.timestamp)

        self.node.tpdo[2].add_callback(copy)
        sync_ms = 10
        self.network.sync.start(sync_ms / 1000)
        time.sleep(2.6)
        self.network.sync.stop()
        time.sleep(0.05)
        self.assertGreater(len(times), 150)
        # The window: whole sine periods after the first 0.3 s.
        t0 = times[0] + 0.3
        periods = int((times[-1] - t0) * SINE_HZ)
        print(f"LOOPBACK {t0:.6f} {t0 + periods / SINE_HZ:.6f} {sync_ms}")
        self.node.tpdo[2].callbacks.clear()

    def test_09_emcy_on_faults(self):
        self.node.emcy.reset()
        # Heartbeat loss: the module watches node 0x7F (the master) at 200 ms; on the loss
        # AO1 takes its fault value (0x6443:01 = 1, 0x6444:01).
        self.node.sdo.download(0x6444, 1, (0x0800).to_bytes(4, "little"))
        self.node.rpdo[2][0].raw = 0x3000
        self.node.rpdo[2][1].raw = 0
        self.node.rpdo[2].transmit()
        print("RPDO AO 12288,0")
        self.node.sdo.download(0x1016, 1, (0x7F << 16 | 200).to_bytes(4, "little"))
        beat = self.network.send_periodic(0x77F, [0x05], 0.05)
        time.sleep(0.5)
        beat.stop()
        e = self.node.emcy.wait(0x8130, 2)
        self.assertIsNotNone(e, "no EMCY 0x8130 after the heartbeat stopped")
        self.assertEqual(e.data[0], 0x7F)
        self.assertTrue(e.register & 0x10, "communication bit of 0x1001")
        heartbeat_loss = 0x8130 | e.register << 16 | 0x7F << 24
        time.sleep(0.05)
        # 0x1029:01 = 0: the node went to pre-operational.
        self.assertEqual(self.up(0x1001), e.register)
        print(f"FAULT AO 2048 after EMCY {e.code:#06x}, 0x1001 = {e.register:#04x}")
        self.node.sdo.download(0x1016, 1, (0).to_bytes(4, "little"))
        # An output out of range (negative): EMCY 0xFF01, manufacturer bit of 0x1001.
        self.node.nmt.state = "OPERATIONAL"
        time.sleep(0.05)
        self.node.rpdo[2][0].raw = -100
        self.node.rpdo[2].transmit()
        e = self.node.emcy.wait(0xFF01, 2)
        self.assertIsNotNone(e, "no EMCY 0xFF01 for a negative output")
        self.assertEqual(e.data[0], 0x01)
        self.assertTrue(e.register & 0x80)
        # 0x1003: the EMCYs newest first (code, 0x1001, first data byte); 0 clears it.
        history = [self.up(0x1003, s) for s in range(1, self.up(0x1003) + 1)]
        print("0x1003 " + " ".join(f"{v:#010x}" for v in history))
        self.assertEqual(history[0], 0xFF01 | e.register << 16 | 0x01 << 24)
        self.assertIn(heartbeat_loss, history)
        self.assertEqual(self.abort_code(
            lambda: self.node.sdo.download(0x1003, 0, b"\x01")), 0x06090030)
        self.assertEqual(self.abort_code(
            lambda: self.node.sdo.download(0x1003, 1, b"\0\0\0\0")), 0x06010002)
        self.node.sdo.download(0x1003, 0, b"\x00")
        self.assertEqual(self.up(0x1003), 0)
        self.assertEqual(self.abort_code(lambda: self.node.sdo.upload(0x1003, 1)), 0x08000024)


if __name__ == "__main__":
    result = unittest.main(exit=False, verbosity=2).result
    sys.exit(0 if result.wasSuccessful() else 1)
