//! FAULT CAMPAIGN (issue 14 section 2), the PDI side: the SII EEPROM busy or not loaded at
//! start-up, and corrupted PDI accesses (a bit flipped on the SPI wires, SPI_SEL dropped in
//! the middle of a transaction). The firmware's slave application on the virtual board,
//! driven by the scripted master; the faults are the ESC model's switches.

mod fault_common;
use fault_common::*;
use virtual_board::models::esc::{cmd, regs};
use virtual_board::rig::firmware_cpu::{INIT_EEPROM_WAIT_NS, TICK_NS};
use virtual_board::rig::scripted::{state, ScriptedMaster, Sync};

const SM_SYNC: Sync = Sync::SmSync { cycle_ns: CYCLE };

/// 0x0502 bits: checksum error (b11), EEPROM not loaded (b12), busy (b15).
const EEPROM_CHECKSUM_ERROR: u16 = 0x0800;
const EEPROM_NOT_LOADED: u16 = 0x1000;
const EEPROM_BUSY: u16 = 0x8000;

/// The EEPROM takes 30 ms to load after power-up. Meanwhile the ESC answers frames, its
/// EEPROM interface is busy, the PDI is down; the firmware's init waits (within its 100 ms
/// bound) and touches nothing on the SPI; the master's SII read waits for the busy bit.
/// The firmware starts once the EEPROM is in, and the master reaches OP. The outputs stay
/// at 0 V until then.
#[test]
fn eeprom_busy_at_start_up() {
    let load = 30_000_000;
    let m = ScriptedMaster::firmware(|c| c.esc.eeprom_load_ns = load);
    m.wait(1_000_000);
    // Before the station address is set, by broadcast reads.
    let brd = |addr| {
        let (d, wkc) = m.datagram(cmd::BRD, 0, addr, &[0; 2]).unwrap();
        assert_eq!(wkc, 1, "the ESC answers while it loads");
        u16::from_le_bytes([d[0], d[1]])
    };
    let ctl = brd(regs::EEPROM_CONTROL);
    assert_eq!(
        ctl & (EEPROM_BUSY | EEPROM_NOT_LOADED),
        EEPROM_BUSY | EEPROM_NOT_LOADED
    );
    assert_eq!(brd(regs::DL_STATUS) & 1, 0, "PDI not operational");
    assert_eq!(spi_stats(&m).transactions, 0, "nothing on the SPI");
    assert_eq!(firmware_stats(&m).init_pdi_ready, None, "init waits");
    // The master reads the SII as soon as it may.
    let info = m.init().unwrap();
    assert_eq!(
        info.identity[1],
        firmware::products::analog_io::identity::IDENTITY.product_code
    );
    assert!(m.now_ns() >= load);
    let fw = firmware_stats(&m);
    assert_eq!(fw.init_pdi_ready, Some(true), "loaded within the bound");
    assert!(
        (load..load + 200_000).contains(&fw.init_done_ns),
        "init ended {} us after the load",
        (fw.init_done_ns - load) / 1000
    );
    assert_eq!(m.dac(), [0, 0]);
    m.to_op(SM_SYNC, |_| Ok(())).unwrap();
    good_cycles(&m, 5, 0x1000, 0x2000);
    assert_eq!(m.dac(), [dac_code(0x1000), dac_code(0x2000)]);
    assert_eq!(spi_stats(&m).errors, 0);
}

/// The EEPROM's configuration area has a bad checksum: the ESC does not load it, the PDI
/// stays down. The firmware's init waits its 100 ms, reports the timeout and goes on (the
/// tick and the ADC run: no hang), without a single SPI access to the unconfigured ESC.
/// The master sees it (0x0502 checksum error and not loaded, 0x0110 PDI not operational);
/// a state request stays unanswered (AL status INIT, no code: nobody behind the ESC). The
/// master repairs the checksum and reloads: the firmware starts within a tick and the
/// master reaches OP. The outputs stay at 0 V throughout.
#[test]
fn eeprom_not_loaded_at_start_up() {
    let m = ScriptedMaster::firmware(|c| c.esc.sii[14] ^= 0xFF);
    m.wait(INIT_EEPROM_WAIT_NS + 20 * TICK_NS);
    let fw = firmware_stats(&m);
    assert_eq!(fw.init_pdi_ready, Some(false), "timeout reported");
    assert_eq!(
        fw.init_done_ns, INIT_EEPROM_WAIT_NS,
        "after the bounded wait"
    );
    assert!(fw.ticks >= 19, "the firmware runs on ({} ticks)", fw.ticks);
    assert!(fw.adc_frames > 1000);
    assert_eq!(
        spi_stats(&m).transactions,
        0,
        "no access to an unconfigured PDI"
    );
    m.init().unwrap();
    let ctl = m.read_u16(regs::EEPROM_CONTROL).unwrap();
    assert_eq!(
        ctl & (EEPROM_CHECKSUM_ERROR | EEPROM_NOT_LOADED),
        EEPROM_CHECKSUM_ERROR | EEPROM_NOT_LOADED
    );
    assert_eq!(m.read_u16(regs::DL_STATUS).unwrap() & 1, 0);
    m.configure_mailbox().unwrap();
    let s = m.request_state(state::PREOP).unwrap();
    assert_eq!(s.pair(), (state::INIT, 0), "unanswered");
    assert_eq!(m.dac(), [0, 0]);

    // Repair: the right checksum into word 7, reload.
    let words = m.sii_words(0, 7).unwrap();
    let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
    m.sii_write_word(7, u16::from(coe_core::sii::crc8(&bytes)))
        .unwrap();
    let ctl = m.sii_reload().unwrap();
    assert_eq!(ctl & (EEPROM_CHECKSUM_ERROR | EEPROM_NOT_LOADED), 0);
    assert_eq!(m.read_u16(regs::DL_STATUS).unwrap() & 1, 1);
    m.wait(TICK_NS);
    assert!(spi_stats(&m).transactions > 0, "started within a tick");
    // The request from before is served now.
    let s = m.al_status().unwrap();
    assert_eq!(s.pair(), (state::PREOP, 0));
    m.request_state(state::INIT).unwrap();
    m.to_op(SM_SYNC, |_| Ok(())).unwrap();
    good_cycles(&m, 5, 0x0300, 0x0400);
    assert_eq!(m.dac(), [dac_code(0x0300), dac_code(0x0400)]);
    assert_eq!(spi_stats(&m).errors, 0);
}

/// The outputs of cycle `i`: both bytes equal, so a flipped bit or a byte from elsewhere
/// never forms another output of the sequence.
fn output(i: usize) -> i16 {
    let b = (i % 120 + 2) as i16;
    b << 8 | b
}

/// Corrupted reads of the outputs, in SM-synchronous and in DC mode: every bit of the SM2
/// read's data flipped on MISO (the ESC cannot see it), bits of its address and command
/// flipped on MOSI, SPI_SEL dropped at every byte (the ESC counts a PDI error, 0x030D, and
/// the MCU reads the idle bus). One fault per cycle, 60 cycles in a row: no value the
/// master did not send ever reaches the DAC, every cycle's outputs arrive (the read is
/// confirmed and retried), the module stays in OP, and the ESC's PDI error counter the
/// master can read shows the SEL drops, which the module reports with an Emergency 0x5000.
#[test]
fn corrupted_output_reads_never_reach_the_dac() {
    use virtual_board::models::spi::{SpiFault, SpiTarget};
    for sync in [
        SM_SYNC,
        Sync::Dc {
            cycle_ns: CYCLE as u32,
        },
    ] {
        let m = op_with(sync, [Some(0x0123), Some(0x0456)]);
        good_cycles(&m, 10, output(0), output(0));
        let sm2 = m.sm(2).unwrap().start;
        let mut faults = Vec::new();
        for byte in 3..7 {
            for bit in 0..8 {
                faults.push(SpiFault::FlipMiso { byte, bit });
            }
        }
        for byte in 0..2 {
            for bit in 0..8 {
                faults.push(SpiFault::FlipMosi { byte, bit });
            }
        }
        for byte in 2..7 {
            faults.push(SpiFault::DropSel { byte });
        }
        let loads_before = dac_loads(&m).len();
        for (i, fault) in faults.iter().enumerate() {
            m.board()
                .borrow()
                .esc()
                .borrow_mut()
                .spi_faults
                .inject(SpiTarget::Read(sm2), *fault);
            good_cycles(&m, 1, output(i + 1), output(i + 1));
            m.wait(CYCLE);
            assert_eq!(
                m.dac(),
                [dac_code(output(i + 1)); 2],
                "{sync:?}: the outputs of cycle {i} arrived despite {fault:?}"
            );
        }
        let injected = m.board().borrow().esc().borrow().spi_faults.injected.len();
        assert_eq!(injected, faults.len(), "every fault hit an SM2 read");
        for (t, ch, code) in &dac_loads(&m)[loads_before..] {
            let v = (code >> 1) as i16;
            assert!(
                *code & 1 == 0 && v >> 8 == v & 0xFF,
                "{sync:?}: the DAC took {code:#06x} on channel {ch} at {t} ns"
            );
        }
        assert_eq!(al(&m), (state::OP, 0));
        let pdi_errors = m.read(regs::PDI_ERROR_COUNTER, 1).unwrap()[0];
        assert!(
            pdi_errors >= 3,
            "0x030D counts the reads cut in their data: {pdi_errors}"
        );
        // Reported: an Emergency 0x5000 with the ESC's counter, within the safety service.
        m.wait(150_000_000);
        let e = emergencies(&m);
        assert!(
            e.iter()
                .any(|e| e.code == emcy::PDI_ERROR && e.data[0] >= 3),
            "{sync:?}: {e:?}"
        );
    }
}

/// A bit flipped while the firmware writes its AL status (the state answering a request)
/// or reads AL control: the master still sees the state it asked for, without an error;
/// the firmware reads back what it wrote and confirms what it read.
#[test]
fn corrupted_al_status_and_control_accesses() {
    use virtual_board::models::spi::{SpiFault, SpiTarget};
    let m = master();
    m.configure_mailbox().unwrap();
    let inject = |target, fault| {
        m.board()
            .borrow()
            .esc()
            .borrow_mut()
            .spi_faults
            .inject(target, fault)
    };
    // AL status written with its state bit 2 flipped (PREOP 0x02 -> 0x06).
    inject(
        SpiTarget::Write(regs::AL_STATUS),
        SpiFault::FlipMosi { byte: 2, bit: 2 },
    );
    let s = m.request_state(state::PREOP).unwrap();
    m.wait(2 * TICK_NS);
    assert_eq!(s.state, state::PREOP);
    assert_eq!(al(&m), (state::PREOP, 0));
    // AL control read with bit 3 flipped (SAFEOP 0x04 -> 0x0C, undefined).
    inject(
        SpiTarget::Read(regs::AL_CONTROL),
        SpiFault::FlipMiso { byte: 3, bit: 3 },
    );
    m.configure_process_data(SM_SYNC).unwrap();
    let s = m.request_state(state::SAFEOP).unwrap();
    assert_eq!(
        s.pair(),
        (state::SAFEOP, 0),
        "no 0x0012 for a state never asked"
    );
    let injected = m.board().borrow().esc().borrow().spi_faults.injected.len();
    assert_eq!(injected, 2);
}
