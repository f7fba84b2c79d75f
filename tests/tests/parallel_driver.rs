//! The et1100 driver's `MemoryPdi` on the ESC model's 16-bit µC front end, behind seed
//! 004's multiplexed FSMC bank, against its `SpiPdi` on the SPI front end: the slave
//! application (the `analog-io` product's, unchanged) makes the same ESC accesses through
//! both, and the two ESCs end in the same state after every step of a master's walk to OP
//! with a mailbox exchange, process data and the DC registers.

use et1100::{BusWidth, Et1100, MemoryPdi, Pdi, SpiPdi};
use firmware::io::analog::outputs::OutputStage;
use firmware::platform::board;
use firmware::platform::stm32f1::clocks::CLOCKS;
use firmware::platform::stm32f1::{esc_pdi, fsmc};
use firmware::products::analog_io::{application, Application, CONFIG};
use firmware::stacks::ethercat::SlaveApp;
use virtual_board::models::esc::parallel::{BusTiming, EscFsmcBus, FsmcCycle};
use virtual_board::models::esc::{regs, Esc, EscConfig};
use virtual_board::models::shared_esc::SharedEsc;
use virtual_board::models::spi::EscSpi;
use virtual_board::rig::sii_builder::SiiBuilder;

/// The FSMC's phases from the STM32 board's BTR1 at its HCLK (address 27 ns, data 83 ns,
/// turnaround 13 ns at 72 MHz).
fn fsmc_cycle() -> FsmcCycle {
    let (address, strobe, turnaround) = fsmc::TIMING.phases_ns(CLOCKS.hclk_hz());
    FsmcCycle {
        address_ns: address.into(),
        strobe_ns: strobe.into(),
        turnaround_ns: turnaround.into(),
    }
}

/// The process image of the analog I/O's default PDOs: 2 AO (SM2), 8 AI (SM3).
const OUTPUTS: u16 = 4;
const INPUTS: u16 = 16;

/// One side: an ESC, the driver on its front end, the slave application and its stage.
struct Side<P: Pdi> {
    esc: SharedEsc,
    driver: Et1100<P>,
    app: SlaveApp<Application>,
    stage: OutputStage,
}

impl<P: Pdi> Side<P>
where
    P::BusError: core::fmt::Debug,
{
    fn new(esc: SharedEsc, pdi: P) -> Self {
        let mut side = Self {
            esc,
            driver: Et1100::new(pdi),
            app: SlaveApp::new(CONFIG, application()),
            stage: OutputStage::new(),
        };
        side.app.start(&mut side.driver).unwrap();
        side
    }

    /// The PDI task as the board runs it: the IRQ handler while the (level) line is
    /// asserted, then the background poll.
    fn serve(&mut self, now_ns: u64) {
        let mut mailbox = false;
        for _ in 0..8 {
            if !self.esc.borrow().irq() {
                break;
            }
            let out = self
                .app
                .on_pdi_irq(&mut self.driver, &self.stage, now_ns)
                .unwrap();
            mailbox |= out.serve_mailbox;
        }
        let out = self
            .app
            .poll(&mut self.driver, &self.stage, now_ns)
            .unwrap();
        // The mailbox task, below the PDI task, when either asked for it.
        if mailbox || out.serve_mailbox {
            self.app
                .serve_mailbox(&mut self.driver, &self.stage, now_ns)
                .unwrap();
        }
    }
}

fn sii(word0: u16, word1: u16) -> Vec<u8> {
    SiiBuilder::new()
        .identity(0x0000_0A5E, 0x0000_1754, 1, 7)
        .config_word(0, word0)
        .config_word(1, word1)
        .build()
}

/// The master's side of one step, done the same on both ESCs.
fn both(a: &SharedEsc, b: &SharedEsc, step: impl Fn(&mut Esc)) {
    step(&mut a.borrow_mut());
    step(&mut b.borrow_mut());
}

fn config_sm(esc: &mut Esc, n: usize, len: u16) {
    let d = &CONFIG.sm[n];
    let mut r = [0u8; 8];
    r[..2].copy_from_slice(&d.start.to_le_bytes());
    r[2..4].copy_from_slice(&len.to_le_bytes());
    r[4] = d.control;
    r[6] = 0x01;
    esc.ecat_write(regs::SM_BASE + 8 * n as u16, &r);
}

fn al_control(esc: &mut Esc, state: u8) {
    esc.ecat_write(regs::AL_CONTROL, &[state, 0]);
}

/// An SDO upload request of 0x1018:01 (vendor ID) in a mailbox of SM0's size.
fn sdo_upload_request() -> Vec<u8> {
    let mut m = vec![0u8; usize::from(CONFIG.sm[0].len)];
    // Mailbox header: length 10, address 0, channel 0, type CoE (3) with counter 1.
    m[..6].copy_from_slice(&[10, 0, 0, 0, 0, 0x13]);
    // CoE header: SDO request (2 << 12); SDO: initiate upload, 0x1018:01.
    m[6..8].copy_from_slice(&0x2000u16.to_le_bytes());
    m[8..12].copy_from_slice(&[0x40, 0x18, 0x10, 0x01]);
    m
}

/// The ESC memory the application reaches, without the PDI configuration bytes (0x0140..
/// 0x0153 differ by design: SPI 0x0E05/0x0603, µC 0x0E08/0x0600).
fn state(esc: &SharedEsc) -> Vec<(u16, u8)> {
    let e = esc.borrow();
    (0u16..0x3000)
        .filter(|a| !(0x0140..0x0154).contains(a))
        .map(|a| (a, e.peek_u8(a)))
        .collect()
}

fn assert_same(spi: &SharedEsc, par: &SharedEsc, step: &str) {
    let (a, b) = (state(spi), state(par));
    let diff: Vec<_> = a
        .iter()
        .zip(&b)
        .filter(|(x, y)| x != y)
        .map(|(x, y)| (format!("{:#06x}", x.0), x.1, y.1))
        .take(8)
        .collect();
    assert!(diff.is_empty(), "{step}: (address, SPI, µC) {diff:?}");
}

#[test]
fn the_slave_application_sees_the_same_esc_through_both_front_ends() {
    // At both ends of the UNCONFIRMED BUSY range: the ESC's state must not depend on it.
    for (timing, name) in [
        (BusTiming::NO_CLASH, "no frame clash"),
        (BusTiming::FRAME_CLASH, "every access clashing"),
    ] {
        walk_to_op(timing, name);
    }
}

/// The master's walk to OP and 20 process-data cycles on both ESCs, compared after every
/// step; the FSMC's figures printed with `name`.
fn walk_to_op(timing: BusTiming, name: &str) {
    let spi_esc = SharedEsc::new(Esc::new(EscConfig::new(sii(
        board::PDI.word0(),
        board::PDI.word1(),
    ))));
    let par_esc = SharedEsc::new(Esc::new(EscConfig::new(sii(
        esc_pdi::PDI.word0(),
        esc_pdi::PDI.word1(),
    ))));
    assert_eq!(par_esc.borrow().peek_u8(regs::PDI_CONTROL), 0x08);
    let fsmc = EscFsmcBus::new(par_esc.clone(), timing, fsmc_cycle());
    let mut spi = Side::new(spi_esc.clone(), SpiPdi::new(EscSpi::new(spi_esc.clone())));
    let mut par = Side::new(par_esc.clone(), MemoryPdi::new(fsmc, BusWidth::Bits16));
    assert_same(&spi_esc, &par_esc, "start");
    let mut now = 0u64;
    let mut serve = |spi: &mut Side<_>, par: &mut Side<_>| {
        now += 100_000;
        spi.serve(now);
        par.serve(now);
        assert_eq!(spi.app.state(), par.app.state());
    };

    // INIT -> PRE-OP with the mailbox SyncManagers.
    both(&spi_esc, &par_esc, |e| {
        config_sm(e, 0, CONFIG.sm[0].len);
        config_sm(e, 1, CONFIG.sm[1].len);
        al_control(e, 0x02);
    });
    serve(&mut spi, &mut par);
    assert_eq!(par_esc.borrow().peek_u16(regs::AL_STATUS), 0x0002);
    assert_same(&spi_esc, &par_esc, "PRE-OP");

    // An SDO upload: the request into SM0, the reply out of SM1.
    both(&spi_esc, &par_esc, |e| {
        e.ecat_write(CONFIG.sm[0].start, &sdo_upload_request());
    });
    for _ in 0..3 {
        serve(&mut spi, &mut par);
    }
    let mut replies = [vec![], vec![]];
    for (esc, reply) in [&spi_esc, &par_esc].into_iter().zip(&mut replies) {
        let mut e = esc.borrow_mut();
        assert!(e.sm_mailbox_full(1), "a reply waits in SM1");
        *reply = vec![0u8; usize::from(CONFIG.sm[1].len)];
        e.ecat_read(CONFIG.sm[1].start, reply);
    }
    assert_eq!(replies[0], replies[1]);
    // Upload response, expedited 4 bytes, 0x1018:01 (the product's vendor ID).
    assert_eq!(replies[1][8..12], [0x43, 0x18, 0x10, 0x01]);
    assert_same(&spi_esc, &par_esc, "SDO upload");

    // PRE-OP -> SAFE-OP -> OP with the process-data SyncManagers, then process data.
    both(&spi_esc, &par_esc, |e| {
        config_sm(e, 2, OUTPUTS);
        config_sm(e, 3, INPUTS);
        al_control(e, 0x04);
    });
    serve(&mut spi, &mut par);
    assert_eq!(par_esc.borrow().peek_u16(regs::AL_STATUS), 0x0004);
    both(&spi_esc, &par_esc, |e| {
        e.ecat_write(CONFIG.sm[2].start, &[0x00, 0x10, 0x00, 0xF0]);
        al_control(e, 0x08);
    });
    serve(&mut spi, &mut par);
    assert_eq!(par_esc.borrow().peek_u16(regs::AL_STATUS), 0x0008);
    let mut per_cycle = (0, 0);
    for cycle in 0..20u8 {
        both(&spi_esc, &par_esc, |e| {
            e.ecat_write(CONFIG.sm[2].start, &[cycle, 0x20, !cycle, 0x10]);
        });
        let before = {
            let bus = par.driver.pdi_mut().bus_mut();
            (bus.accesses, bus.bus_ns)
        };
        serve(&mut spi, &mut par);
        let bus = par.driver.pdi_mut().bus_mut();
        per_cycle = (bus.accesses - before.0, bus.bus_ns - before.1);
        let mut inputs = [vec![0u8; INPUTS.into()], vec![0u8; INPUTS.into()]];
        spi_esc
            .borrow_mut()
            .ecat_read(CONFIG.sm[3].start, &mut inputs[0]);
        par_esc
            .borrow_mut()
            .ecat_read(CONFIG.sm[3].start, &mut inputs[1]);
        assert_eq!(inputs[0], inputs[1], "cycle {cycle}");
        assert_eq!(
            spi.stage.staged(),
            par.stage.staged(),
            "cycle {cycle}: staged outputs"
        );
    }
    assert_same(&spi_esc, &par_esc, "OP");

    // The DC registers the application reads: system time (latched by the first byte),
    // the cyclic unit's activation, SYNC0 status.
    let spi_dc = (
        spi.driver.system_time().unwrap(),
        spi.driver.sync_activation().unwrap(),
        spi.driver.sync0_status().unwrap(),
    );
    let par_dc = (
        par.driver.system_time().unwrap(),
        par.driver.sync_activation().unwrap(),
        par.driver.sync0_status().unwrap(),
    );
    assert_eq!(spi_dc, par_dc);
    assert_same(&spi_esc, &par_esc, "DC");

    // No access was refused or invalid, and the SPI side saw no PDI error.
    let bus = par.driver.destroy().destroy();
    let s = &bus.port().stats;
    assert_eq!((s.refused, s.invalid), (0, 0));
    assert!(s.word_reads > 0 && s.byte_writes > 0);
    assert_eq!(spi_esc.borrow().peek_u8(regs::PDI_ERROR_COUNTER), 0);
    eprintln!(
        "FSMC, {name}: per process-data cycle (SM2 event, outputs, inputs) {} accesses, {} ns",
        per_cycle.0, per_cycle.1
    );
    eprintln!(
        "FSMC, {name}: {} accesses ({} word reads, {} byte reads, {} word writes, {} byte writes), \
         {} ns on the bus, {} ns of it BUSY",
        bus.accesses,
        s.word_reads,
        s.byte_reads,
        s.word_writes,
        s.byte_writes,
        bus.bus_ns,
        s.busy_ns
    );
}

#[test]
fn fsmc_byte_accesses_through_the_driver() {
    let esc = SharedEsc::new(Esc::new(EscConfig::new(sii(
        esc_pdi::PDI.word0(),
        esc_pdi::PDI.word1(),
    ))));
    let fsmc = EscFsmcBus::new(esc.clone(), BusTiming::NO_CLASH, fsmc_cycle());
    let mut pdi = MemoryPdi::new(fsmc, BusWidth::Bits16);
    // Odd start, odd length: a high-lane byte, a word, a low-lane byte.
    pdi.write(0x1201, &[0x11, 0x22, 0x33, 0x44]).unwrap();
    assert_eq!(esc.borrow().peek_u32(0x1200), 0x3322_1100);
    assert_eq!(esc.borrow().peek_u16(0x1204), 0x0044);
    let mut b = [0u8; 3];
    pdi.read(0x1201, &mut b).unwrap();
    assert_eq!(b, [0x11, 0x22, 0x33]);
    pdi.read(0x1204, &mut b[..1]).unwrap();
    assert_eq!(b[0], 0x44);
    let bus = pdi.destroy();
    let s = &bus.port().stats;
    // Each call starts with its event word; the FSMC reads whole halfwords, so the
    // driver's byte reads are word reads on the ESC: 3 events + 2 + 1 data.
    assert_eq!((s.byte_reads, s.word_reads), (0, 3 + 2 + 1));
    assert_eq!((s.byte_writes, s.word_writes), (2, 1));
    assert_eq!(bus.accesses, 9);
}
