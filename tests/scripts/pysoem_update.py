"""A firmware update of the first slave through SOEM (pysoem), as SOEM's firm_update does it:
INIT, SM0/SM1 on the bootstrap mailbox read from the SII (words 0x14..0x17), BOOT, FoE writes,
INIT; then the slave is brought to PRE-OP again and its identity read over SDO.

Used by tests/tests/system_update_pysoem.rs (the virtual board on the other end of a veth pair)
and usable by hand against a real module:

    python3 tests/scripts/pysoem_update.py IFACE FILE.efw [BAD.efw ...]

Every BAD file is written first and must be refused; FILE.efw last must be accepted (FILE "-":
no file is to be accepted, and the old application must answer afterwards). One line of JSON per
step goes to stdout; the exit code is 0 when every step went as expected.
"""

import argparse
import json
import os
import struct
import sys
import time

import pysoem

# SII word addresses of the bootstrap mailbox (ETG.2010): receive (master -> slave), send.
SII_BOOT_RX_MBX = 0x0014
SII_BOOT_TX_MBX = 0x0016
TIMEOUT_US = 5_000_000


def report(**fields):
    print(json.dumps(fields), flush=True)


def reach(slave, state):
    slave.state = state
    slave.write_state()
    got = slave.state_check(state, TIMEOUT_US)
    if got != state:
        raise RuntimeError(
            f"state {state:#x} not reached: {got:#x}, AL status code {slave.al_status:#06x}"
        )


def emergency(e):
    """The module's Emergencies are reported, not raised (pysoem raises them from the
    mailbox call that received them otherwise)."""
    report(step="emergency", fields=[int(a) for a in e.args])


def product_code(slave):
    """The running application's product code (0x1018:02)."""
    return struct.unpack("<I", slave.sdo_read(0x1018, 2))[0]


def describe(e):
    """The exception as text; pysoem's WkcError has no message, only a working counter."""
    text = f"{type(e).__name__}: {e}"
    wkc = getattr(e, "wkc", None)
    return text if wkc is None else f"{text} (working counter {wkc})"


def main(iface, good, bad):
    # SOEM's default timeouts (2 ms per datagram): the module answers every frame at once.
    master = pysoem.Master()
    master.open(iface)
    try:
        found = master.config_init()
        if found < 1:
            raise RuntimeError("no slave found")
        slave = master.slaves[0]
        slave.add_emergency_callback(emergency)
        report(step="found", name=slave.name, vendor=slave.man, product=slave.id,
               revision=slave.rev)
        reach(slave, pysoem.PREOP_STATE)
        version = slave.sdo_read(0x100A, 0).decode(errors="replace")
        report(step="version before", version=version, product=product_code(slave))

        reach(slave, pysoem.INIT_STATE)
        rx_addr, rx_len = struct.unpack("<HH", slave.eeprom_read(SII_BOOT_RX_MBX))
        tx_addr, tx_len = struct.unpack("<HH", slave.eeprom_read(SII_BOOT_TX_MBX))
        report(step="bootstrap mailbox", out=[rx_addr, rx_len], **{"in": [tx_addr, tx_len]})
        slave.amend_mbx(mailbox="out", start_address=rx_addr, size=rx_len)
        slave.amend_mbx(mailbox="in", start_address=tx_addr, size=tx_len)
        reach(slave, pysoem.BOOT_STATE)
        report(step="boot")

        ok = True
        for path in bad + ([] if good == "-" else [good]):
            with open(path, "rb") as f:
                data = f.read()
            # SOEM returns > 0 for a file the slave took; an FoE error from the slave comes
            # back as a negative result or (pysoem) as an exception.
            try:
                result = slave.foe_write(os.path.basename(path), 0, data, TIMEOUT_US)
                error = None
            except Exception as e:  # pysoem's error types differ between versions
                result, error = None, describe(e)
            accepted = result is not None and result > 0
            report(step="foe write", file=os.path.basename(path), bytes=len(data),
                   result=result, error=error, accepted=accepted)
            ok = ok and accepted == (path == good)

        # BOOT -> INIT: the bootloader installs the file and starts the new application.
        slave.state = pysoem.INIT_STATE
        slave.write_state()
    finally:
        master.close()
    # The installation takes a while (the flash erased and written, then the application's
    # start): a new master session, as a user starts one, until the new application is in
    # PRE-OP and answers, bounded. (A new session each time: SOEM keeps every mailbox error
    # in its list, and pysoem raises the oldest from later calls.)
    deadline = time.monotonic() + 20
    while True:
        time.sleep(0.5)
        master = pysoem.Master()
        master.open(iface)
        try:
            found = master.config_init()
            slave = master.slaves[0]
            slave.add_emergency_callback(emergency)
            if slave.state_check(pysoem.PREOP_STATE, TIMEOUT_US) == pysoem.PREOP_STATE:
                version = slave.sdo_read(0x100A, 0).decode(errors="replace")
                product = product_code(slave)
                state = slave.state
                break
        except Exception:
            if time.monotonic() > deadline:
                raise
        finally:
            master.close()
        if time.monotonic() > deadline:
            raise RuntimeError("the new application did not reach PRE-OP")
    report(step="back", found=found, state=state)
    report(step="version after", version=version, product=product)
    return 0 if ok else 1


if __name__ == "__main__":
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("iface", help="the network interface the module is on")
    parser.add_argument("file", help="the update file that must be accepted (*.efw)")
    parser.add_argument("bad", nargs="*", help="update files that must be refused, written first")
    args = parser.parse_args()
    try:
        sys.exit(main(args.iface, args.file, args.bad))
    except Exception as e:  # the test shows the message
        report(step="error", message=describe(e))
        sys.exit(1)
