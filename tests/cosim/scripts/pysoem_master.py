#!/usr/bin/env python3
"""SOEM through pysoem as an independent master of the module on a network interface, with
SOEM's default timeouts (2 ms per datagram), as a user runs it.

    python3 pysoem_master.py IFACE [CYCLES [CYCLE_US]]

PRE-OP (SOEM reads the SII), SDO uploads of the identity (0x1000, 0x1008, 0x1018:01..04), DC
(config_dc, SYNC0 every CYCLE_US, default 4000), the process-data mapping (config_map, which
asks for SAFE-OP), SAFE-OP, OP, CYCLES process-data exchanges (default 2000) in step with
SYNC0: the master writes a new AO pair every cycle and reads the AI values back (it reports
the pairs the module took and each input's lowest and highest value, for the caller to check
against the board's DAC and ADC); the cycle monitor's counters (0x1C32:0B, 0x0C, 0x20) over SDO while the cycle goes on. Then the SM
watchdog: back to PRE-OP, SYNC0 off, OP in SM-synchronous mode, and the master stops sending:
the module must fall to SAFE-OP with the error flag and AL status code 0x001B. Then PRE-OP,
the object dictionary through SDO Information, and INIT.

The process data run in a thread of their own from SAFE-OP on, beside the mailbox and the
state changes, as a master's cyclic task does: in DC mode the module counts every SYNC0
cycle without fresh outputs (ETG.1020) and leaves OP when they stop. Run as root, the master
runs at real-time priority (SCHED_FIFO), as that task must on a loaded host. Even so a
Python thread woke up to 2.4 ms late on the project's 2-core machine under load (1 in 2 500
wake-ups later than 0.5 ms): the default cycle of 4 ms keeps the frames half a cycle, 2 ms,
ahead of SYNC0. Emergencies the module sends are reported as steps, not raised.

With `--slowdown N` the board's clock runs N times slower than the wall clock (`cargo xtask
sim --iface ... --slowdown N`): the master's cycle and its waits on the module's time are N
times as long, SOEM's own timeouts are not.

One JSON object per line on stdout: {"step": ..., ...}; the last line is {"step": "done",
"ok": true|false}. The exit code is 0 only when every step worked.
"""

import argparse
import json
import os
import struct
import sys
import threading
import time

import pysoem

# Priority of the master below the board's frame-answering thread (tools::iface).
MASTER_PRIORITY = 30
# Process data in SAFE-OP before asking for OP (longer than SOEM's 100 ms SYNC0 start delay).
SAFE_OP_S = 0.3
# SM watchdog test: the master stays silent this long (the ESC's default is 100 ms).
SILENCE_S = 0.5
# AL status code of an expired SM watchdog.
SM_WATCHDOG = 0x001B
# SOEM's state timeout (EC_TIMEOUTSTATE).
STATE_US = pysoem.settings.timeouts.state
# The board's clock this many times slower than the wall clock (`--slowdown`): the master's
# cycle and its waits on the module's time are as many times as long.
SLOWDOWN = 1


def say(**kv):
    print(json.dumps(kv), flush=True)


def realtime():
    """SCHED_FIFO for this process (and the threads it starts) when allowed (root)."""
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(MASTER_PRIORITY))
        return True
    except (PermissionError, AttributeError, OSError):
        return False


def wait_state(master, slave, state, timeout_us=STATE_US):
    """Requests `state` and waits for it (SOEM's state_check, repeated)."""
    slave.state = state
    slave.write_state()
    deadline = time.monotonic() + timeout_us / 1e6
    while time.monotonic() < deadline:
        if slave.state_check(state, 50_000) == state:
            return True
    master.read_state()
    return slave.state == state


def acknowledge(slave, state, timeout_us=STATE_US):
    """Acknowledges an error in `state` (state + ACK) and waits until the error flag is
    clear. SOEM's state_check compares the state without the error flag, so it returns
    before the module has taken the acknowledge; a state request written then would
    replace it in AL control."""
    slave.state = state + pysoem.STATE_ACK
    slave.write_state()
    deadline = time.monotonic() + timeout_us / 1e6
    while time.monotonic() < deadline:
        slave.state_check(state, 50_000)
        if slave.state == state:
            return True
    return False


class Cyclic(threading.Thread):
    """The master's cyclic task: one process-data exchange every cycle, with DC in step with
    SYNC0: the frames pass the module half a cycle before each SYNC0 edge (SOEM's ec_sync
    control on the DC time the frames bring back). Counts the exchanges with the expected
    working counter and the cycles it started late (no sleep before the frame, or the frame
    sent a quarter cycle or more after its time).

    While `recording`, it keeps what a checker of the module's outputs and inputs needs:
    each output pair the module took (an exchange with the expected working counter), once
    however many exchanges carried it, with a flag when the module may rightly never have
    put it out (a late cycle beside it: the next frame then followed at once and may have
    replaced it before the SYNC0 edge); and the lowest and highest value of every input."""

    def __init__(self, master, slave, cycle_ns, dc, slowdown=1):
        super().__init__(daemon=True)
        self.master, self.slave, self.cycle_ns, self.dc = master, slave, cycle_ns, dc
        # A board slowed down N times (`--slowdown N`) runs its DC clock N times slower than
        # the wall clock: the cycle on the wall clock is N DC cycles long.
        self.slowdown = slowdown
        self.wall_cycle_ns = cycle_ns * slowdown
        # Where the frames pass the module after each SYNC0 edge (DC ns), and a shift of the
        # next deadline still to make when it moves (wall ns).
        self.phase_ns = cycle_ns // 2
        self.shift_ns = 0
        self.running = True
        self.lock = threading.Lock()
        self.exchanges = self.good = self.late = 0
        self.outputs = (0, 0)
        self.inputs = []
        self.integral = 0
        self.recording = False
        self.taken = []
        self.ai_min, self.ai_max = None, None

    def run(self):
        due = time.monotonic_ns()
        was_late = skipped = False
        while self.running:
            outputs = self.write_outputs()
            self.master.send_processdata()
            # The frame left before the send returned. Sent a quarter cycle or more after its
            # time (a sleep that overslept on a stalled host, or no sleep at all), it may
            # have passed the module after the SYNC0 edge it was meant for, and the next
            # frame then replaces its outputs before they are put out.
            late = skipped or time.monotonic_ns() - due >= self.wall_cycle_ns // 4
            wkc = self.master.receive_processdata()
            answered = wkc == self.master.expected_wkc
            with self.lock:
                self.exchanges += 1
                self.good += answered
                self.late += late
                self.inputs = list(struct.unpack("<8h", bytes(self.slave.input[:16])))
            self.on_exchange(outputs, answered, was_late or late)
            was_late = late
            due += self.wall_cycle_ns + self.offset()
            left = due - time.monotonic_ns()
            skipped = left <= 0
            if not skipped:
                time.sleep(left / 1e9)

    def write_outputs(self):
        """The output pair of this cycle, put in the output image."""
        with self.lock:
            outputs = self.outputs
            self.slave.output = struct.pack("<hh", *outputs)
        return outputs

    def on_exchange(self, outputs, answered, late_beside):
        """After each exchange: its outputs recorded. An unanswered exchange's frame may
        still have passed the module (its answer came after SOEM's receive timeout), so its
        pair may reach the DAC, or rightly never."""
        self.record(outputs, late_beside or not answered, answered)

    def record(self, outputs, may_be_replaced, answered):
        with self.lock:
            if not self.recording:
                return
            if self.taken and self.taken[-1][:2] == list(outputs):
                self.taken[-1][2] = self.taken[-1][2] and may_be_replaced
            else:
                self.taken.append([*outputs, may_be_replaced])
            if not answered:
                return
            if self.ai_min is None:
                self.ai_min, self.ai_max = list(self.inputs), list(self.inputs)
            self.ai_min = [min(a, b) for a, b in zip(self.ai_min, self.inputs)]
            self.ai_max = [max(a, b) for a, b in zip(self.ai_max, self.inputs)]

    def offset(self):
        """The correction of the next wall-clock deadline (ns) that keeps the frames
        `phase_ns` after the SYNC0 edges (half a cycle unless moved with `move_to`)."""
        if not self.dc:
            return 0
        with self.lock:
            phase, shift, self.shift_ns = self.phase_ns, self.shift_ns, 0
        # The frame's DC time against the SYNC0 edges (SYNC0 at multiples of the cycle).
        delta = (self.master.dc_time - phase) % self.cycle_ns
        if delta > self.cycle_ns // 2:
            delta -= self.cycle_ns
        self.integral += 1 if delta > 0 else -1 if delta < 0 else 0
        return shift + (-(delta // 100) - (self.integral // 20)) * self.slowdown

    def move_to(self, phase_ns):
        """From the next cycle on, the frames pass the module `phase_ns` after the SYNC0
        edges (DC ns, 0 < phase_ns < cycle): one step, not the control loop's slow pull."""
        with self.lock:
            self.shift_ns += (phase_ns - self.phase_ns) * self.slowdown
            self.phase_ns = phase_ns

    def figures(self):
        with self.lock:
            return self.exchanges, self.good, self.late, self.inputs

    def stop(self):
        self.running = False
        self.join()


def emergency(e):
    """pysoem's Emergency: slave position, error code, error register, then the data."""
    say(step="emergency", fields=[int(a) for a in e.args])


def u16(slave, index, sub):
    return struct.unpack("<H", slave.sdo_read(index, sub)[:2])[0]


# Sync Error Counter Limit for this master (0x10F1:02; each missed SM event adds 3, each good
# cycle takes 1 off): a few late cycles of a non-real-time host do not trip it.
SYNC_ERROR_LIMIT = 30


def text(name):
    return name.decode("ascii", "replace") if isinstance(name, bytes) else str(name)


def sdo_info(slave):
    """The object dictionary as SDO Information gives it (SOEM's readODlist, readODdescription
    and readOE for every object)."""
    objects = {}
    for obj in slave.od:
        objects[f"{obj.index:#06x}"] = {
            "name": text(obj.name),
            "entries": [text(e.name) for e in obj.entries],
        }
    return objects


def go_op(master, slave):
    """SAFE-OP with the cycle running, then OP."""
    ok = wait_state(master, slave, pysoem.SAFEOP_STATE)
    time.sleep(SAFE_OP_S * SLOWDOWN)
    return ok and wait_state(master, slave, pysoem.OP_STATE)


def run_op(master, slave, cycles, cycle_ns, monitor=True):
    """DC mode: OP, `cycles` exchanges with new outputs each, the cycle monitor over SDO
    (when `monitor`), then PRE-OP with the cycle still running."""
    if not wait_state(master, slave, pysoem.SAFEOP_STATE):
        master.read_state()
        say(step="safeop", ok=False, state=slave.state, al_status_code=slave.al_status)
        return False
    cyclic = Cyclic(master, slave, cycle_ns, True, SLOWDOWN)
    cyclic.start()
    try:
        say(step="safeop", ok=True, sync_mode=u16(slave, 0x1C32, 1))
        time.sleep(SAFE_OP_S * SLOWDOWN)
        in_op = wait_state(master, slave, pysoem.OP_STATE)
        say(step="op", ok=in_op, state=slave.state, al_status_code=slave.al_status)
        if not in_op:
            return False
        start, good_before, late_before, _ = cyclic.figures()
        done = start
        with cyclic.lock:
            cyclic.recording = True
        while done < start + cycles:
            i = done - start
            # A new pair every cycle, none repeated within 32 767 cycles (97 and 89 are
            # prime to 0x7FFF), so each DAC code names the exchange that brought it.
            with cyclic.lock:
                cyclic.outputs = ((i * 97) % 0x7FFF, 0x7FFF - (i * 89) % 0x7FFF)
            time.sleep(cyclic.wall_cycle_ns / 4e9)
            done, good, late, ai = cyclic.figures()
        with cyclic.lock:
            cyclic.recording = False
        # The last pair taken goes out at the next SYNC0 edge: the cycle keeps sending it
        # until then, before anything here may take the module out of OP.
        time.sleep(2 * cyclic.wall_cycle_ns / 1e9)
        master.read_state()
        say(
            step="process_data",
            cycles=done - start,
            good_wkc=good - good_before,
            late_cycles=late - late_before,
            last_outputs=list(cyclic.outputs),
            ai=ai,
            ai_min=cyclic.ai_min,
            ai_max=cyclic.ai_max,
            outputs_taken=cyclic.taken,
            state=slave.state,
            al_status_code=slave.al_status,
        )
        # A cycle the master itself started late (the exchange and its 2 ms receive timeout
        # took more than a whole cycle) is a host that did not run for milliseconds; a
        # working counter missed then is not held against the slave, any other is.
        missed = (done - start) - (good - good_before)
        ok = missed <= late - late_before and slave.state == pysoem.OP_STATE
        if not monitor:
            return wait_state(master, slave, pysoem.PREOP_STATE) and ok
        # The module's cycle monitor (ETG.1020), read in OP while the cycle goes on.
        monitor = {
            "sm_event_missed": u16(slave, 0x1C32, 0x0B),
            "cycle_time_too_small": u16(slave, 0x1C32, 0x0C),
            "sync_error": slave.sdo_read(0x1C32, 0x20)[0],
        }
        say(step="sync_monitor", **monitor)
        return wait_state(master, slave, pysoem.PREOP_STATE) and ok
    finally:
        cyclic.stop()


def watchdog(master, slave, cycle_ns):
    """The SM watchdog in SM-synchronous mode (in DC mode the cycle monitor would see the
    silence first, 0x001A): OP, then no more frames."""
    slave.dc_sync(False, cycle_ns)
    cyclic = Cyclic(master, slave, cycle_ns, False, SLOWDOWN)
    cyclic.start()
    try:
        ok = go_op(master, slave)
        mode = u16(slave, 0x1C32, 1) if ok else None
    finally:
        cyclic.stop()
    silent_from = time.monotonic()
    time.sleep(SILENCE_S * SLOWDOWN)
    master.read_state()
    state, code = slave.state, slave.al_status
    tripped = state == pysoem.SAFEOP_STATE + pysoem.STATE_ERROR and code == SM_WATCHDOG
    # Acknowledge the error (SAFE-OP + ACK), as a master does.
    acked = acknowledge(slave, pysoem.SAFEOP_STATE)
    say(
        step="watchdog",
        ok=ok and tripped and acked,
        sync_mode=mode,
        silent_s=round(time.monotonic() - silent_from, 3),
        state=state,
        al_status_code=code,
        acknowledged=acked,
    )
    return ok and tripped and acked


def main():
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("iface", help="the network interface the module is on")
    parser.add_argument(
        "cycles", nargs="?", type=int, default=2000, help="process-data exchanges in OP"
    )
    parser.add_argument(
        "cycle_us", nargs="?", type=int, default=4000, help="the DC cycle (SYNC0) in us"
    )
    parser.add_argument(
        "--op-only",
        action="store_true",
        help="only PRE-OP, SDO, DC, OP with the exchanges and INIT: for a slave without the "
        "module's cycle monitor objects (0x1C32:0B..0x20), such as a SOES peer",
    )
    parser.add_argument(
        "--slowdown",
        type=int,
        default=1,
        help="the board's clock this many times slower than the wall clock "
        "(`cargo xtask sim --slowdown N`)",
    )
    args = parser.parse_args()
    global SLOWDOWN
    SLOWDOWN = args.slowdown
    iface, cycles, cycle_ns = args.iface, args.cycles, args.cycle_us * 1000
    say(step="master", realtime=realtime(), timeout_us=pysoem.settings.timeouts.ret)
    master = pysoem.Master()
    # The cyclic thread and the mailbox run side by side.
    master.always_release_gil = True
    master.open(iface)
    try:
        n = master.config_init()
        say(step="config_init", slaves=n)
        if n != 1:
            return False
        slave = master.slaves[0]
        slave.add_emergency_callback(emergency)
        say(
            step="sii",
            name=slave.name,
            vendor=slave.man,
            product=slave.id,
            revision=slave.rev,
        )
        # config_init asked for PRE-OP; the module's firmware takes it.
        preop = slave.state_check(pysoem.PREOP_STATE, STATE_US)
        say(step="state", state=preop, al_status_code=slave.al_status)
        if preop != pysoem.PREOP_STATE:
            return False
        device_type = struct.unpack("<I", slave.sdo_read(0x1000, 0))[0]
        name = slave.sdo_read(0x1008, 0).decode("ascii", "replace")
        identity = [struct.unpack("<I", slave.sdo_read(0x1018, s))[0] for s in range(1, 5)]
        say(step="sdo", device_type=device_type, name=name, identity=identity)
        if not args.op_only:
            # This master is a Python thread on a host that is not real-time: a cycle it
            # starts late misses an SM event. Its users raise the module's Sync Error Counter
            # Limit (0x10F1:02) for such a master; the cycle monitor still counts every
            # missed event (read below).
            slave.sdo_write(0x10F1, 2, struct.pack("<H", SYNC_ERROR_LIMIT))
        # SYNC0 runs before PRE-OP -> SAFE-OP (which SOEM's config_map asks for): the module
        # takes its sync mode from the ESC then.
        dc = master.config_dc()
        slave.dc_sync(True, cycle_ns)
        say(step="dc", found=bool(dc), cycle_ns=cycle_ns)
        size = master.config_map()
        say(step="config_map", bytes=size, outputs=len(slave.output), inputs=len(slave.input))
        ok = run_op(master, slave, cycles, cycle_ns, monitor=not args.op_only)
        if args.op_only:
            wait_state(master, slave, pysoem.INIT_STATE)
            say(step="init", state=slave.state, al_status_code=slave.al_status)
            return ok
        ok = watchdog(master, slave, cycle_ns) and ok
        # SDO Information last: SOEM asks for every subindex up to the highest, the gaps too
        # (0x1C32:0E..1F), which the module answers with an SDO Information error; SOEM keeps
        # those in its error list, and pysoem raises them from the next calls that look at it.
        ok = wait_state(master, slave, pysoem.PREOP_STATE) and ok
        say(step="sdo_info", objects=sdo_info(slave))
        wait_state(master, slave, pysoem.INIT_STATE)
        say(step="init", state=slave.state, al_status_code=slave.al_status)
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
