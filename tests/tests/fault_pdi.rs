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
        firmware::product::identity::IDENTITY.product_code
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
