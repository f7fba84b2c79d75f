//! The `analog-io-stm32` product as its image runs it, on the host: its own SII (generated
//! from its device description, the 16-bit µC PDI) loaded by the ESC model, its slave
//! application over the et1100 driver's `MemoryPdi` on the ESC's parallel front end behind
//! the board's FSMC bank. A master's walk to OP with an SDO upload of the product's
//! identity and process data, and BOOT refused (the product has no bootloader).

use et1100::{BusWidth, Et1100, MemoryPdi};
use firmware::io::analog::outputs::{DacPair, OutputStage, StageKind};
use firmware::io::analog::scaling::ao_to_dac_code;
use firmware::platform::stm32f1::clocks::CLOCKS;
use firmware::platform::stm32f1::fsmc;
use firmware::products::analog_io_stm32::device::DEVICE;
use firmware::products::analog_io_stm32::identity::IDENTITY;
use firmware::products::analog_io_stm32::{application, Application, CONFIG};
use firmware::stacks::ethercat::SlaveApp;
use virtual_board::models::esc::parallel::{BusTiming, EscFsmcBus, FsmcCycle};
use virtual_board::models::esc::{regs, Esc, EscConfig};
use virtual_board::models::shared_esc::SharedEsc;

type Driver = Et1100<MemoryPdi<EscFsmcBus>>;

struct Module {
    esc: SharedEsc,
    driver: Driver,
    app: SlaveApp<Application>,
    stage: OutputStage,
    now: u64,
}

impl Module {
    /// The ESC with the product's EEPROM, the application started on the FSMC bus.
    fn new() -> Self {
        let mut eeprom = vec![0xFFu8; DEVICE.eeprom.size_bytes as usize];
        coe_core::sii::generate_eeprom(&DEVICE, &mut eeprom).expect("the product's SII");
        let esc = SharedEsc::new(Esc::new(EscConfig::new(eeprom)));
        assert_eq!(
            esc.borrow().peek_u8(regs::PDI_CONTROL),
            0x08,
            "the SII configures the 16-bit µC PDI"
        );
        let (address, strobe, turnaround) = fsmc::TIMING.phases_ns(CLOCKS.hclk_hz());
        let cycle = FsmcCycle {
            address_ns: address.into(),
            strobe_ns: strobe.into(),
            turnaround_ns: turnaround.into(),
        };
        let bus = EscFsmcBus::new(esc.clone(), BusTiming::NO_CLASH, cycle);
        let mut driver = Et1100::new(MemoryPdi::new(bus, BusWidth::Bits16));
        let mut app = SlaveApp::new(CONFIG, application());
        app.start(&mut driver).expect("the application starts");
        Self {
            esc,
            driver,
            app,
            stage: OutputStage::new(),
            now: 0,
        }
    }

    /// The PDI task: the IRQ handler while the line is asserted, then the background poll;
    /// then the mailbox task below it.
    fn serve(&mut self) {
        self.now += 1_000_000;
        let mut mailbox = false;
        for _ in 0..8 {
            if !self.esc.borrow().irq() {
                break;
            }
            let out = self
                .app
                .on_pdi_irq(&mut self.driver, &self.stage, self.now)
                .expect("no bus error");
            mailbox |= out.serve_mailbox;
        }
        let out = self
            .app
            .poll(&mut self.driver, &self.stage, self.now)
            .expect("no bus error");
        // The mailbox task, below the PDI task, when either asked for it.
        if mailbox || out.serve_mailbox {
            self.app
                .serve_mailbox(&mut self.driver, &self.stage, self.now)
                .expect("no bus error");
        }
    }

    fn config_sm(&self, n: usize, len: u16) {
        let d = &CONFIG.sm[n];
        let mut r = [0u8; 8];
        r[..2].copy_from_slice(&d.start.to_le_bytes());
        r[2..4].copy_from_slice(&len.to_le_bytes());
        r[4] = d.control;
        r[6] = 0x01;
        self.esc
            .borrow_mut()
            .ecat_write(regs::SM_BASE + 8 * n as u16, &r);
    }

    /// Requests `state`, serves, returns AL status and AL status code.
    fn request(&mut self, state: u8) -> (u16, u16) {
        self.esc
            .borrow_mut()
            .ecat_write(regs::AL_CONTROL, &[state, 0]);
        self.serve();
        let e = self.esc.borrow();
        (
            e.peek_u16(regs::AL_STATUS),
            e.peek_u16(regs::AL_STATUS_CODE),
        )
    }
}

#[test]
fn the_product_reaches_op_on_the_fsmc_and_answers_with_its_identity() {
    let mut m = Module::new();
    m.config_sm(0, CONFIG.sm[0].len);
    m.config_sm(1, CONFIG.sm[1].len);
    assert_eq!(m.request(0x02), (0x0002, 0));

    // SDO upload of 0x1018:02, the product code.
    let mut request = vec![0u8; usize::from(CONFIG.sm[0].len)];
    request[..6].copy_from_slice(&[10, 0, 0, 0, 0, 0x13]);
    request[6..8].copy_from_slice(&0x2000u16.to_le_bytes());
    request[8..12].copy_from_slice(&[0x40, 0x18, 0x10, 0x02]);
    m.esc.borrow_mut().ecat_write(CONFIG.sm[0].start, &request);
    for _ in 0..3 {
        m.serve();
    }
    let mut reply = vec![0u8; usize::from(CONFIG.sm[1].len)];
    assert!(m.esc.borrow().sm_mailbox_full(1), "a reply waits in SM1");
    m.esc.borrow_mut().ecat_read(CONFIG.sm[1].start, &mut reply);
    assert_eq!(reply[8..12], [0x43, 0x18, 0x10, 0x02]);
    assert_eq!(
        u32::from_le_bytes([reply[12], reply[13], reply[14], reply[15]]),
        IDENTITY.product_code
    );

    // SAFE-OP and OP with the default PDOs: 2 AO out, 8 AI in.
    m.config_sm(2, 4);
    m.config_sm(3, 16);
    assert_eq!(m.request(0x04), (0x0004, 0));
    m.esc
        .borrow_mut()
        .ecat_write(CONFIG.sm[2].start, &[0x00, 0x10, 0x00, 0xF0]);
    assert_eq!(m.request(0x08), (0x0008, 0));
    for cycle in 0..5u8 {
        m.esc
            .borrow_mut()
            .ecat_write(CONFIG.sm[2].start, &[cycle, 0x20, 0, 0x10]);
        m.serve();
        let ao1 = i16::from_le_bytes([cycle, 0x20]);
        assert_eq!(
            m.stage.staged(),
            (
                StageKind::Outputs,
                DacPair {
                    a: ao_to_dac_code(ao1),
                    b: ao_to_dac_code(0x1000),
                }
            ),
            "cycle {cycle}: the outputs staged for the DAC"
        );
    }
    let stats = &m.driver.pdi_mut().bus_mut().port().stats;
    assert_eq!((stats.refused, stats.invalid), (0, 0));
}

#[test]
fn boot_is_refused_without_a_bootloader() {
    let mut m = Module::new();
    // INIT -> BOOT: error flag, state INIT, "bootstrap not supported" (ETG.1000.6 0x0013).
    assert_eq!(m.request(0x03), (0x0011, 0x0013));
}
