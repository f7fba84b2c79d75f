//! The oversampling op modes of the description ([`op_modes`](super::super::op_modes))
//! against the firmware's own admission: the product's application, driven like a master
//! drives it, takes each mode's assignment over SDO at the mode's cycle and goes to SAFEOP
//! (the minimum cycle, the SyncManagers, `oversampling::admit`, `output_blocks::admit`).
//! So the ESI offers nothing the module refuses and hides nothing it serves.

use super::Rig;
use crate::io::analog::output_blocks::{UPDATES_PER_PDO, UPDATE_PDO, UPDATE_PDOS};
use crate::io::analog::oversampling::{PERIOD_NS, SAMPLE_PDO, SAMPLE_PDOS};
use crate::products::analog_io::device::DEVICE;
use crate::products::analog_io::op_modes::{CycleOpMode, CYCLE_OP_MODES, OP_MODES};
use crate::products::analog_io::{application, CONFIG, OVERSAMPLING};
use coe_core::device::oversampling::{OpModePdo, OpModeSm};
use coe_core::AlStatusCode;
use std::format;
use std::string::String;
use std::vec::Vec;

/// The PDOs an op mode's `Sm` element assigns, in order: a group's base and its replicas.
fn assigned(pdos: &[OpModePdo]) -> Vec<u16> {
    pdos.iter()
        .flat_map(|p| (0..u16::from(p.copies())).map(move |k| p.index + k))
        .collect()
}

/// Bytes of the image of `pdos` (their default mappings in the dictionary).
fn image_bytes(pdos: &[u16]) -> u16 {
    let bits: u32 = pdos
        .iter()
        .flat_map(|p| DEVICE.pdo_entries(*p))
        .map(|e| u32::from(e.bit_len))
        .sum();
    bits.div_ceil(8) as u16
}

fn sm_pdos(mode: &CycleOpMode, sm: u8) -> Vec<u16> {
    let sms: &[OpModeSm] = mode.mode.sms;
    let found = sms.iter().find(|s| s.sm == sm);
    assigned(found.map_or(&[][..], |s| s.pdos))
}

/// Writes `pdos` into the assignment object `index` (sub 0 = 0, the entries, sub 0 = n).
pub(super) fn assign(r: &mut Rig, index: u16, pdos: &[u16]) -> Result<(), String> {
    let refused = |e: u32| format!("{index:#06X} refused: abort {e:#010X}");
    r.download(index, 0, &[0]).map_err(refused)?;
    for (sub, pdo) in (1u8..).zip(pdos) {
        r.download(index, sub, &pdo.to_le_bytes())
            .map_err(refused)?;
    }
    r.download(index, 0, &[pdos.len() as u8]).map_err(refused)
}

/// PREOP -> SAFEOP of the product's application with `rx`/`tx` in 0x1C12/0x1C13, SM2 and
/// SM3 as long as their images (at the layout's addresses), DC SYNC0 with `cycle_ns`, no
/// SYNC1: `Ok` when admitted, else what refused it.
fn safeop(rx: &[u16], tx: &[u16], cycle_ns: u32) -> Result<(), String> {
    let mut r = Rig::with_app(CONFIG, application());
    let [m0, m1, sm2, sm3] = CONFIG.sm;
    r.esc.master_sm(0, m0.start, m0.len, m0.control, true);
    r.esc.master_sm(1, m1.start, m1.len, m1.control, true);
    assert_eq!(r.request(0x02), (0x02, 0));
    assign(&mut r, 0x1C12, rx)?;
    assign(&mut r, 0x1C13, tx)?;
    r.esc
        .master_sm(2, sm2.start, image_bytes(rx), sm2.control, true);
    r.esc
        .master_sm(3, sm3.start, image_bytes(tx), sm3.control, true);
    r.esc.master_dc(0x03, cycle_ns);
    match r.request(0x04) {
        (0x04, 0) => Ok(()),
        (state, code) => Err(format!("AL status {state:#04X}, code {code:#06X}")),
    }
}

/// The update PDOs 0x1620.. of `n` groups (none for 0).
fn updates(n: usize) -> Vec<u16> {
    (0..n as u16).map(|u| UPDATE_PDO + u).collect()
}

/// `pdos` with the sample PDOs replaced by the first `n` of them.
fn with_samples(pdos: &[u16], n: usize) -> Vec<u16> {
    let mut out: Vec<u16> = pdos.iter().copied().filter(|p| !is_sample(*p)).collect();
    out.extend((0..n as u16).map(|b| SAMPLE_PDO + b));
    out
}

fn is_sample(pdo: u16) -> bool {
    (SAMPLE_PDO..SAMPLE_PDO + SAMPLE_PDOS as u16).contains(&pdo)
}

fn is_update(pdo: u16) -> bool {
    (UPDATE_PDO..UPDATE_PDO + UPDATE_PDOS as u16).contains(&pdo)
}

/// The description lists exactly these modes, after the plain ones, with the plain "DC"
/// mode's synchronisation: SYNC0 = the bus cycle (AssignActivate 0x0300, factor 1), no
/// SYNC1; each assigns both process-data SyncManagers.
#[test]
fn the_op_modes_are_the_plain_dc_mode_with_an_assignment() {
    let dc = DEVICE
        .dc
        .op_modes
        .iter()
        .find(|m| m.assign_activate != 0)
        .expect("a plain DC mode");
    assert_eq!((dc.assign_activate, dc.sync0_factor), (0x0300, 1));
    assert_eq!(OVERSAMPLING.op_modes, &OP_MODES[..]);
    assert!(!OP_MODES.is_empty());
    for (mode, listed) in CYCLE_OP_MODES.iter().zip(OVERSAMPLING.op_modes) {
        assert_eq!(&mode.mode, listed);
        let m = mode.mode.mode;
        assert_eq!(
            (
                m.assign_activate,
                m.sync_mode,
                m.sync0_factor,
                m.cycle_time_sync0
            ),
            (
                dc.assign_activate,
                dc.sync_mode,
                dc.sync0_factor,
                dc.cycle_time_sync0
            ),
            "{}",
            m.name
        );
        assert_eq!((m.sync1_factor, m.shift_time_sync1), (0, 0), "{}", m.name);
        let sms: Vec<u8> = mode.mode.sms.iter().map(|s| s.sm).collect();
        assert_eq!(sms, [2, 3], "{}", m.name);
    }
    let cycles: Vec<u32> = CYCLE_OP_MODES.iter().map(|m| m.cycle_ns).collect();
    assert!(cycles.windows(2).all(|w| w[0] > w[1]), "one mode per cycle");
}

/// Every op mode's assignment is admitted at its cycle.
#[test]
fn every_op_mode_is_admitted_at_its_cycle() {
    for mode in &CYCLE_OP_MODES {
        let (rx, tx) = (sm_pdos(mode, 2), sm_pdos(mode, 3));
        assert_eq!(
            safeop(&rx, &tx, mode.cycle_ns),
            Ok(()),
            "{} at {} ns: 0x1C12 {rx:04X?}, 0x1C13 {tx:04X?}",
            mode.mode.mode.name,
            mode.cycle_ns
        );
    }
}

/// At each mode's cycle: the inputs take the fewest sample PDOs the admission accepts (one
/// fewer is refused with 0x001E, too few for the cycle's largest block: every conversion
/// reaches the master, in the fewest bytes), and beside them the outputs take the most
/// update PDOs it accepts (none when no update PDO is accepted: then the one-value
/// outputs), so the op modes neither offer what the firmware refuses nor hide what it serves.
#[test]
fn each_op_mode_takes_the_largest_factor_admitted_at_its_cycle() {
    for mode in &CYCLE_OP_MODES {
        let name = mode.mode.mode.name;
        let (rx, tx) = (sm_pdos(mode, 2), sm_pdos(mode, 3));
        let samples = tx.iter().filter(|p| is_sample(**p)).count();
        assert!(samples > 0, "{name}: sample PDOs");
        let fewer = with_samples(&tx, samples - 1);
        let too_few = format!(
            "AL status 0x12, code {:#06X}",
            u16::from(AlStatusCode::InvalidInputConfiguration)
        );
        assert_eq!(
            safeop(&rx, &fewer, mode.cycle_ns),
            Err(too_few),
            "{name}: {} sample PDOs",
            samples - 1
        );
        let offered = rx.iter().filter(|p| is_update(**p)).count();
        let plain: Vec<u16> = rx.iter().copied().filter(|p| !is_update(*p)).collect();
        let admitted: Vec<usize> = (1..=UPDATE_PDOS)
            .filter(|n| {
                let rx = match offered {
                    0 => updates(*n),
                    _ => [plain.clone(), updates(*n)].concat(),
                };
                safeop(&rx, &tx, mode.cycle_ns).is_ok()
            })
            .collect();
        assert_eq!(
            admitted.iter().max().copied().unwrap_or(0),
            offered,
            "{name}: update PDOs admitted {admitted:?}"
        );
    }
}

/// The cycles a TwinCAT task commonly runs at, and the module's minimum: the input stream
/// (status, time, any number of sample PDOs, the one-value outputs) is admitted at one of
/// them exactly when an op mode is made for it.
#[test]
fn an_op_mode_for_every_common_cycle_that_streams() {
    let cycles = [
        100_000, 125_000, 200_000, 250_000, 270_000, 500_000, 1_000_000, 2_000_000,
    ];
    for cycle in cycles {
        let streams = (1..=SAMPLE_PDOS).any(|n| {
            let tx = with_samples(&[0x1A10, 0x1A11], n);
            safeop(&[0x1600], &tx, cycle).is_ok()
        });
        let offered = CYCLE_OP_MODES.iter().any(|m| m.cycle_ns == cycle);
        assert_eq!(offered, streams, "{cycle} ns");
    }
}

/// What TwinCAT shows says what the mode does: the cycle, the input rate (every conversion
/// of the eight channels) and the output updates per second.
#[test]
fn the_descriptions_say_the_cycle_and_the_rates() {
    for mode in &CYCLE_OP_MODES {
        let m = mode.mode.mode;
        let cycle = match mode.cycle_ns {
            c if c % 1_000_000 == 0 => format!("{} ms", c / 1_000_000),
            c => format!("{} us", c / 1_000),
        };
        let updates = match sm_pdos(mode, 2).iter().filter(|p| is_update(**p)).count() {
            0 => 1,
            n => n * UPDATES_PER_PDO,
        };
        let khz = updates as f64 * 1e6 / f64::from(mode.cycle_ns);
        let ao = match khz.fract() {
            0.0 => format!("AO {khz:.0} kHz"),
            _ => format!("AO {khz:.1} kHz"),
        };
        let ai = format!("AI {} kSPS", 1_000_000 / PERIOD_NS);
        let expected = format!("DC-OS {cycle}: {ai}, {ao}");
        assert_eq!(m.description, expected, "{}", m.name);
    }
}
