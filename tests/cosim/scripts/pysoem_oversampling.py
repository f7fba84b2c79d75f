#!/usr/bin/env python3
"""SOEM through pysoem with the module's oversampling PDOs (docs/book/oversampling.md):

    python3 pysoem_oversampling.py IFACE [CYCLES [CYCLE_US [SAMPLE_PDOS [SLOWDOWN [UPDATE_PDOS]]]]]

PRE-OP; the input assignment over SDO (0x1C13: sub 0 = 0, the block status 0x1A10, the
block time 0x1A11, the sample PDOs 0x1A20.., sub 0 = n), as the book tells SOEM users;
0x8000:03 (the slots it gives) read back. With UPDATE_PDOS (default 0) the output assignment
too (0x1C12: the update PDOs 0x1620.., five updates of AO1 and AO2 each); SAMPLE_PDOS 0
leaves the inputs as they are (no stream), but for the block status 0x1A10 after the plain
inputs when there are update PDOs: its status byte says which cycles' outputs held (b2)
and which blocks the module refused (b3). DC with SYNC0 every CYCLE_US (default 1000);
config_map, which reads the assignment and the mappings over CoE and sizes the image;
SAFE-OP, OP, and CYCLES process-data exchanges (default 1000) in a thread of their own,
each keeping the input image as it came. Then INIT. With CYCLES 0: INIT right after OP.

The outputs climb: update k of the block the master sends in its exchange i is the pair
(a, !a) with a = (i x n + k) x 97 (mod 2^16), n the updates per cycle, so the caller can
tell from the DAC's loads alone which update of which exchange the module played. The
"outputs" step lists the exchanges kept and those sent late or beside a late one (whose
block the module may rightly never have played), and the exchanges whose input image had
b2 or b3 set.

The blocks are judged after the run: a block read twice (the same scan counter: the master's
frame came before the module wrote the next one) is counted once; for the others the scan
counter must go on where the block before ended (a gap is lost samples, an overlap repeated
ones), no status bit may be set, and the block times must lie on the scan grid. AI1's
samples are printed with their scan counters ([counter, code], the scan counter a clock of
32 us in the ADC's own time) for the test to compare with the ADC model's signal.

SLOWDOWN (default 1) is for a board whose clock runs that many times slower than the wall
clock (`cargo xtask sim --image --iface vb1 --slowdown N`): the master's cycle and its wait in
SAFE-OP are then that many times as long on the wall clock, and it sees the module as at
full speed.

One JSON object per line on stdout: {"step": ..., ...}; the last line is {"step": "done",
"ok": true|false}. The exit code is 0 only when every step worked.
"""

import argparse
import struct
import sys
import time

import pysoem

# The shared master parts (the script's own folder is on the path when run as a file).
from pysoem_master import STATE_US, Cyclic, realtime, say, wait_state

# Process data in SAFE-OP before asking for OP.
SAFE_OP_S = 0.3
# Cycles between moving the frames to their place after SYNC0 and keeping the images.
SETTLE_CYCLES = 20
# Block status, block time, the first sample PDO.
STATUS_PDO, TIME_PDO, SAMPLE_PDO = 0x1A10, 0x1A11, 0x1A20
# The first update PDO, and the updates of AO1 and AO2 each one carries.
UPDATE_PDO, UPDATES_PER_PDO = 0x1620, 5
# How much AO1's code climbs from one update to the next (odd: the code gives the update).
UPDATE_STEP = 97
CHANNELS = 8
PERIOD_NS = 4000
SCAN_NS = CHANNELS * PERIOD_NS
# The block header: scan counter (u32), scans (u8), status (u8), block time (u64).
HEADER = struct.Struct("<IBBQ")
# The plain inputs (0x6401:01..08).
PLAIN_TX_PDO = 0x1A00
# Status bits 2 and 3 of the block status: outputs held, update block refused.
OUTPUTS_HELD, OUTPUTS_REFUSED = 1 << 2, 1 << 3


def update_pair(i, n, k):
    """AO1 and AO2 of update k of the block sent in exchange i."""
    a = ((i * n + k) * UPDATE_STEP) & 0xFFFF
    return a, a ^ 0xFFFF


class Keeping(Cyclic):
    """pysoem_master's cyclic task (one exchange per cycle, locked to the SYNC0 edges),
    keeping every input image (when `images`) and writing n climbing updates per cycle
    (when n > 0)."""

    def __init__(self, master, slave, cycle_ns, slowdown, images, updates):
        super().__init__(master, slave, cycle_ns, True, slowdown)
        self.keep = False
        self.keep_images = images
        self.updates = updates
        self.images = []
        # Exchanges kept: (exchange, late or beside a late one, answered, the last input
        # byte: the block status when 0x1A10 ends the inputs).
        self.sent = []

    def write_outputs(self):
        with self.lock:
            i = self.exchanges
        if self.updates:
            pairs = (update_pair(i, self.updates, k) for k in range(self.updates))
            self.slave.output = b"".join(struct.pack("<HH", *p) for p in pairs)
        return i

    def on_exchange(self, outputs, answered, late_beside):
        with self.lock:
            if self.keep:
                status = self.slave.input[-1] if self.slave.input else 0
                self.sent.append((outputs, late_beside, answered, status))
                if self.keep_images:
                    phase = self.master.dc_time % self.cycle_ns
                    self.images.append((bytes(self.slave.input), late_beside, phase))

    def kept(self):
        with self.lock:
            return len(self.sent)


def assign(slave, index, pdos):
    """0x1C12 or 0x1C13 over SDO, entry by entry (sub 0 = 0 first, the count last); the
    entries as read back."""
    slave.sdo_write(index, 0, bytes([0]))
    for sub, pdo in enumerate(pdos, start=1):
        slave.sdo_write(index, sub, struct.pack("<H", pdo))
    slave.sdo_write(index, 0, bytes([len(pdos)]))
    return [struct.unpack("<H", slave.sdo_read(index, s)[:2])[0] for s in range(1, len(pdos) + 1)]


def judge(images):
    """The blocks' verdict: distinct blocks, lost and repeated scans, flagged blocks, the
    largest distance of a block time from the scan grid, AI1's samples.

    `images` are (input image, the exchange was late or beside a late one, the frame's DC
    time after the SYNC0 edge before it). A frame the
    master itself sent late (its host stalled) may pass the module after the next block was
    written: it skips a block, and the next frame reads that one again. Scans lost or
    repeated at a block a late frame brought are counted apart, as the master's."""
    blocks, repeats = [], 0
    for img, late, phase in images:
        counter, scans, status, t = HEADER.unpack_from(img)
        if blocks and blocks[-1][0] == counter:
            repeats += 1
            continue
        blocks.append((counter, scans, status, t, img, late, phase))
    lost = duplicated = flagged = 0
    lost_late = duplicated_late = 0
    # The first blocks that broke the stream: [block, scan counter, scans missing (+) or
    # repeated (-), status, brought by a late frame, that frame's DC time after the SYNC0
    # edge before it, the same of the frame before].
    breaks = []
    expected = None
    t0 = blocks[0][3] - blocks[0][0] * SCAN_NS if blocks else 0
    off_grid = 0
    ai1 = []
    for k, (counter, scans, status, t, img, late, phase) in enumerate(blocks):
        d = 0
        if expected is not None:
            d = (counter - expected) & 0xFFFFFFFF
            d = d - (1 << 32) if d >= 1 << 31 else d
            if d > 0 and late:
                lost_late += d * CHANNELS
            elif d > 0:
                lost += d * CHANNELS
            elif late:
                duplicated_late += -d * CHANNELS
            else:
                duplicated += -d * CHANNELS
        if (d != 0 or status != 0) and len(breaks) < 10:
            breaks.append([k, counter, d, status, late, phase, blocks[k - 1][6] if k else None])
        expected = (counter + scans) & 0xFFFFFFFF
        flagged += status != 0
        off_grid = max(off_grid, abs(t - (t0 + counter * SCAN_NS)))
        codes = struct.unpack_from(f"<{scans * CHANNELS}H", img, HEADER.size)
        ai1.extend((counter + i, codes[i * CHANNELS]) for i in range(scans))
    return {
        "blocks": len(blocks),
        "repeated_reads": repeats,
        "samples": sum(b[1] for b in blocks) * CHANNELS,
        "scans_range": [min(b[1] for b in blocks), max(b[1] for b in blocks)] if blocks else [],
        "lost": lost,
        "duplicated": duplicated,
        "flagged_blocks": flagged,
        "off_grid_ns": off_grid,
        "first_counter": blocks[0][0] if blocks else None,
        "lost_beside_late_cycles": lost_late,
        "duplicated_beside_late_cycles": duplicated_late,
        "breaks": breaks,
    }, ai1


def main():
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("iface")
    parser.add_argument("cycles", nargs="?", type=int, default=1000)
    parser.add_argument("cycle_us", nargs="?", type=int, default=1000)
    parser.add_argument("sample_pdos", nargs="?", type=int, default=8)
    parser.add_argument("slowdown", nargs="?", type=int, default=1)
    parser.add_argument("update_pdos", nargs="?", type=int, default=0)
    args = parser.parse_args()
    cycle_ns = args.cycle_us * 1000
    updates = args.update_pdos * UPDATES_PER_PDO
    say(step="master", realtime=realtime())
    master = pysoem.Master()
    master.always_release_gil = True
    master.open(args.iface)
    try:
        if master.config_init() != 1:
            say(step="config_init", ok=False)
            return False
        slave = master.slaves[0]
        if slave.state_check(pysoem.PREOP_STATE, STATE_US) != pysoem.PREOP_STATE:
            say(step="preop", ok=False, al_status_code=slave.al_status)
            return False
        pdos = []
        if args.sample_pdos:
            pdos = [STATUS_PDO, TIME_PDO] + [SAMPLE_PDO + b for b in range(args.sample_pdos)]
        elif args.update_pdos:
            pdos = [PLAIN_TX_PDO, STATUS_PDO]
        assigned = assign(slave, 0x1C13, pdos) if pdos else []
        rx_pdos = [UPDATE_PDO + u for u in range(args.update_pdos)]
        rx_assigned = assign(slave, 0x1C12, rx_pdos) if rx_pdos else []
        slots = struct.unpack("<H", slave.sdo_read(0x8000, 3)[:2])[0]
        # The module's time from a SYNC0 edge to the cycle's block in SM3 (0x1C33:06, calc
        # and copy), which the assignment sets.
        copy_ns = struct.unpack("<I", slave.sdo_read(0x1C33, 6)[:4])[0]
        say(
            step="assign",
            pdos=assigned,
            rx_pdos=rx_assigned,
            slots=slots,
            calc_copy_ns=copy_ns,
        )
        dc = master.config_dc()
        slave.dc_sync(True, cycle_ns)
        size = master.config_map()
        say(
            step="config_map",
            found_dc=bool(dc),
            bytes=size,
            inputs=len(slave.input),
            outputs=len(slave.output),
        )
        if not wait_state(master, slave, pysoem.SAFEOP_STATE):
            master.read_state()
            say(step="safeop", ok=False, state=slave.state, al_status_code=slave.al_status)
            return False
        cyclic = Keeping(master, slave, cycle_ns, args.slowdown, bool(args.sample_pdos), updates)
        cyclic.start()
        try:
            time.sleep(SAFE_OP_S * args.slowdown)
            in_op = wait_state(master, slave, pysoem.OP_STATE)
            say(step="op", ok=in_op, state=slave.state, al_status_code=slave.al_status)
            if not in_op:
                return False
            if args.cycles == 0:
                left = wait_state(master, slave, pysoem.INIT_STATE)
                say(step="init", state=slave.state)
                return assigned == pdos and rx_assigned == rx_pdos and left
            # The block of cycle c is in SM3 at most calc-and-copy after SYNC0 edge c, that
            # of cycle c + 1 a cycle later: the frames pass halfway between the two, where a
            # block completed late (a CPU held back) still has half a cycle. The output
            # block they bring plays from the next edge on.
            phase_ns = (copy_ns + cycle_ns // 2) % cycle_ns
            cyclic.move_to(phase_ns)
            say(step="sync", frame_after_sync0_ns=phase_ns)
            time.sleep(SETTLE_CYCLES * cyclic.wall_cycle_ns / 1e9)
            with cyclic.lock:
                cyclic.keep = True
                good_before, exchanges_before = cyclic.good, cyclic.exchanges
            while cyclic.kept() < args.cycles:
                time.sleep(cyclic.wall_cycle_ns / 4e9)
            with cyclic.lock:
                cyclic.keep = False
                images = cyclic.images[: args.cycles]
                sent = cyclic.sent[: args.cycles]
                good = cyclic.good - good_before
                exchanges = cyclic.exchanges - exchanges_before
            master.read_state()
            state_after = slave.state
            in_op = state_after == pysoem.OP_STATE
            # INIT while the cycle still runs: stopped first, the module in DC mode would
            # rightly leave OP with a sync error before the request came.
            wait_state(master, slave, pysoem.INIT_STATE)
        finally:
            cyclic.stop()
        ok = in_op and good == exchanges
        if args.sample_pdos:
            verdict, ai1 = judge(images)
            ok = (
                ok
                and verdict["lost"] == 0
                and verdict["duplicated"] == 0
                and verdict["flagged_blocks"] == 0
            )
            say(step="stream", exchanges=exchanges, good_wkc=good, state=state_after, **verdict)
            say(step="ai1", samples=ai1)
        if updates:
            say(
                step="outputs",
                updates=updates,
                exchanges=exchanges,
                good_wkc=good,
                state=state_after,
                kept=[sent[0][0], sent[-1][0]],
                late=[i for i, late, _, _ in sent if late],
                unanswered=[i for i, _, answered, _ in sent if not answered],
                held=[i for i, _, _, status in sent if status & OUTPUTS_HELD],
                refused=[i for i, _, _, status in sent if status & OUTPUTS_REFUSED],
            )
        master.read_state()
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
