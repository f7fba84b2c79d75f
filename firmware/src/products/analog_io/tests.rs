//! `analog-io` as a whole: the EtherCAT slave application around the analog I/O against a
//! register-file ESC, driven like a master drives a slave.

use super::sync::AnalogFigures;
use crate::fake_esc::FakeEsc;
use crate::io::analog::outputs::{DacAction, DacLatch, DacPair, OutputStage};
use crate::io::analog::process_data::{Mapping, ProcessData};
use crate::io::analog::sampler::Sample;
use crate::io::analog::AnalogIo;
use crate::stacks::ethercat::mailbox::SAFETY_SERVICE_MS;
use crate::stacks::ethercat::pdi_task::{PdiTask, Wake};
use crate::stacks::ethercat::sync::SyncMode;
use crate::stacks::ethercat::*;
use coe_core::device::{MemoryWindow, SmRole, SyncManagerDesc};
use coe_core::od::ObjectDictionary;
use coe_core::od::{Access, DataType, EntryDesc, ObjectDesc, Value};
use coe_core::pdo::PdoEntry;
use coe_core::AlState;
use et1100::AlEvents;
use et1100::Register;
use std::vec;
use std::vec::Vec;

const I16: DataType = DataType::Integer16;
const RWP: Access = Access::RW_PREOP;

static OD: ObjectDictionary = ObjectDictionary::new(&[
    ObjectDesc::var(
        0x1000,
        "Device type",
        &[
            EntryDesc::new(0, "Device type", DataType::Unsigned32, Access::RO)
                .with_default(Value::Uint(0x000C_0191)),
        ],
    ),
    ObjectDesc::var(
        0x1001,
        "Error register",
        &[EntryDesc::new(
            0,
            "Error register",
            DataType::Unsigned8,
            Access::RO,
        )],
    ),
    ObjectDesc::record(
        0x10F1,
        "Error settings",
        DataType::Unknown(0x0040),
        &[
            EntryDesc::count(2),
            EntryDesc::new(1, "Local error reaction", DataType::Unsigned32, Access::RW),
            EntryDesc::new(
                2,
                "Sync error counter limit",
                DataType::Unsigned16,
                Access::RW,
            ),
        ],
    ),
    ObjectDesc::record(
        0x1600,
        "RxPDO 1",
        DataType::PdoMapping,
        &[
            EntryDesc::new(0, "SubIndex 000", DataType::Unsigned8, RWP),
            EntryDesc::new(1, "Entry 1", DataType::Unsigned32, RWP),
            EntryDesc::new(2, "Entry 2", DataType::Unsigned32, RWP),
        ],
    ),
    ObjectDesc::record(
        0x1A00,
        "TxPDO 1",
        DataType::PdoMapping,
        &[
            EntryDesc::new(0, "SubIndex 000", DataType::Unsigned8, RWP),
            EntryDesc::new(1, "Entry 1", DataType::Unsigned32, RWP),
            EntryDesc::new(2, "Entry 2", DataType::Unsigned32, RWP),
        ],
    ),
    ObjectDesc::array(
        0x1C12,
        "RxPDO assign",
        &[
            EntryDesc::new(0, "SubIndex 000", DataType::Unsigned8, RWP),
            EntryDesc::new(1, "Assign 1", DataType::Unsigned16, RWP),
        ],
    ),
    ObjectDesc::record(
        0x1C32,
        "SM output parameter",
        DataType::Unknown(0x0042),
        &[
            EntryDesc::new(0, "SubIndex 000", DataType::Unsigned8, Access::RO),
            EntryDesc::new(1, "Sync mode", DataType::Unsigned16, RWP),
            EntryDesc::new(2, "Cycle time", DataType::Unsigned32, RWP),
            EntryDesc::new(0x0B, "SM event missed", DataType::Unsigned16, Access::RO),
        ],
    ),
    ObjectDesc::array(
        0x6401,
        "AI",
        &[
            EntryDesc::count(2),
            EntryDesc::new(1, "AI 1", I16, Access::RO.tx_mappable()),
            EntryDesc::new(2, "AI 2", I16, Access::RO.tx_mappable()),
        ],
    ),
    ObjectDesc::array(
        0x6411,
        "AO",
        &[
            EntryDesc::count(2),
            EntryDesc::new(1, "AO 1", I16, Access::RW.rx_mappable()),
            EntryDesc::new(2, "AO 2", I16, Access::RW.rx_mappable()),
        ],
    ),
    ObjectDesc::array(
        0x6443,
        "AO error mode",
        &[
            EntryDesc::count(2),
            EntryDesc::new(1, "Mode 1", DataType::Unsigned8, Access::RW),
            EntryDesc::new(2, "Mode 2", DataType::Unsigned8, Access::RW),
        ],
    ),
    ObjectDesc::array(
        0x6444,
        "AO error value",
        &[
            EntryDesc::count(2),
            EntryDesc::new(1, "Value 1", DataType::Integer32, Access::RW),
            EntryDesc::new(2, "Value 2", DataType::Integer32, Access::RW),
        ],
    ),
]);

const MBX_OUT: u16 = 0x1000;
const MBX_IN: u16 = 0x1080;
const PD_OUT: u16 = 0x1100;
const PD_IN: u16 = 0x1180;

fn config() -> AppConfig {
    AppConfig {
        sm: [
            SyncManagerDesc::new(SmRole::MailboxOut, MBX_OUT, 128, 0x26),
            SyncManagerDesc::new(SmRole::MailboxIn, MBX_IN, 128, 0x22),
            SyncManagerDesc::new(SmRole::ProcessDataOut, PD_OUT, 0, 0x64),
            SyncManagerDesc::new(SmRole::ProcessDataIn, PD_IN, 0, 0x20),
        ],
        device_id: Some(0x0042),
        bootstrap: None,
    }
}

const BOOT_OUT: u16 = 0x1000;
const BOOT_IN: u16 = 0x1200;
const BOOT_LEN: u16 = 0x200;

/// With a bootstrap mailbox: INIT -> BOOT resets into the bootloader.
fn boot_config() -> AppConfig {
    AppConfig {
        bootstrap: Some((
            MemoryWindow::new(BOOT_OUT, BOOT_LEN),
            MemoryWindow::new(BOOT_IN, BOOT_LEN),
        )),
        ..config()
    }
}

fn process_data() -> ProcessData {
    ProcessData::new(
        [
            Mapping::with_entries(
                0x1600,
                &[PdoEntry::new(0x6411, 1, 16), PdoEntry::new(0x6411, 2, 16)],
            ),
            Mapping::new(0x1601),
        ],
        [
            Mapping::with_entries(
                0x1A00,
                &[PdoEntry::new(0x6401, 1, 16), PdoEntry::new(0x6401, 2, 16)],
            ),
            Mapping::new(0x1A01),
            Mapping::new(0x1A02),
        ],
        &[0x1600],
        &[0x1A00],
    )
}

struct Rig {
    esc: FakeEsc,
    app: SlaveApp<AnalogIo<AnalogFigures>>,
    stage: OutputStage,
    latch: DacLatch,
    now: u64,
    dac: Vec<DacAction>,
    counter: u8,
}

impl Rig {
    fn new() -> Self {
        Self::with(config())
    }

    fn with(config: AppConfig) -> Self {
        Self::with_app(config, AnalogIo::new(&OD, process_data()))
    }

    /// `io` served with `config`.
    fn with_app(config: AppConfig, io: AnalogIo<AnalogFigures>) -> Self {
        let mut esc = FakeEsc::new();
        let mut app = SlaveApp::new(config, io);
        app.start(&mut esc.driver()).unwrap();
        Self {
            esc,
            app,
            stage: OutputStage::new(),
            latch: DacLatch::new(),
            now: 0,
            dac: Vec::new(),
            counter: 0,
        }
    }

    /// Runs the IRQ handler while the (masked) event bits are set, bounded.
    fn irq(&mut self) {
        for _ in 0..8 {
            if !self.esc.event_request().intersects(self.esc.event_mask()) {
                return;
            }
            self.now += 10_000;
            let out = self
                .app
                .on_pdi_irq(&mut self.esc.driver(), &self.stage, self.now)
                .unwrap();
            self.after(out);
        }
        panic!("IRQ never cleared");
    }

    fn poll(&mut self) {
        self.now += 10_000;
        let out = self
            .app
            .poll(&mut self.esc.driver(), &self.stage, self.now)
            .unwrap();
        self.after(out);
    }

    /// The DAC task if asked, then the mailbox task (below the PDI task) if asked.
    fn after(&mut self, mut out: crate::stacks::ethercat::PdiOutcome) {
        if out.serve_mailbox {
            let mbx = self
                .app
                .serve_mailbox(&mut self.esc.driver(), &self.stage, self.now);
            out.apply_outputs |= mbx.unwrap().apply_outputs;
        }
        if out.apply_outputs {
            let a = self.latch.apply_now(&self.stage);
            self.dac.push(a);
        }
    }

    fn sync0(&mut self) -> DacAction {
        self.now += 10_000;
        let a = self.latch.on_sync0(&self.stage, self.now);
        self.dac.push(a);
        self.poll();
        a
    }

    fn request(&mut self, state: u16) -> (u16, u16) {
        self.esc.master_al_control(state);
        self.irq();
        self.esc.al_status()
    }

    fn mailbox_sms(&mut self) {
        self.esc.master_sm(0, MBX_OUT, 128, 0x26, true);
        self.esc.master_sm(1, MBX_IN, 128, 0x22, true);
    }

    fn pd_sms(&mut self, out_len: u16, in_len: u16) {
        self.esc.master_sm(2, PD_OUT, out_len, 0x64, true);
        self.esc.master_sm(3, PD_IN, in_len, 0x20, true);
    }

    fn goto_preop(&mut self) {
        self.mailbox_sms();
        assert_eq!(self.request(0x02), (0x02, 0));
    }

    fn goto_op(&mut self) {
        self.goto_preop();
        self.pd_sms(4, 4);
        assert_eq!(self.request(0x04), (0x04, 0));
        assert_eq!(self.request(0x08), (0x08, 0));
    }

    fn sdo(&mut self, cmd: u8, index: u16, sub: u8, data: [u8; 4]) -> Vec<u8> {
        self.counter = self.counter % 7 + 1;
        let mut f = vec![10, 0, 0, 0, 0x00, 0x03 | self.counter << 4, 0x00, 0x20, cmd];
        f.extend_from_slice(&index.to_le_bytes());
        f.push(sub);
        f.extend_from_slice(&data);
        assert!(self.esc.master_write_mailbox(&f));
        self.irq();
        self.esc.master_read_mailbox().expect("reply")
    }

    fn download(&mut self, index: u16, sub: u8, value: &[u8]) -> Result<(), u32> {
        let cmd = match value.len() {
            1 => 0x2F,
            2 => 0x2B,
            _ => 0x23,
        };
        let mut d = [0u8; 4];
        d[..value.len()].copy_from_slice(value);
        let r = self.sdo(cmd, index, sub, d);
        match r[8] {
            0x60 => Ok(()),
            0x80 => Err(u32::from_le_bytes(r[12..16].try_into().unwrap())),
            other => panic!("unexpected reply {other:#x}"),
        }
    }

    fn upload(&mut self, index: u16, sub: u8) -> Result<Vec<u8>, u32> {
        let r = self.sdo(0x40, index, sub, [0; 4]);
        match r[8] {
            0x80 => Err(u32::from_le_bytes(r[12..16].try_into().unwrap())),
            cmd if cmd & 0x02 != 0 => {
                let n = 4 - usize::from((cmd >> 2) & 3);
                Ok(r[12..12 + n].to_vec())
            }
            other => panic!("unexpected reply {other:#x}"),
        }
    }

    fn outputs(&mut self, a: i16, b: i16) {
        let mut d = a.to_le_bytes().to_vec();
        d.extend_from_slice(&b.to_le_bytes());
        self.esc.master_write_outputs(&d);
        self.irq();
    }
}

#[test]
fn init_to_op_in_sm_synchronous_mode() {
    let mut r = Rig::new();
    assert_eq!(r.esc.al_status(), (0x01, 0));
    r.goto_op();
    assert_eq!(r.app.sync().mode(), SyncMode::SmSync);
    // OP before any outputs: DAC untouched.
    assert!(r.dac.is_empty());
    r.app
        .application_mut()
        .on_samples(&[Sample::new(0, 0x8000), Sample::new(1, 0xFFFF)]);
    r.outputs(0x4000, 0x1000);
    assert_eq!(
        r.dac.last(),
        Some(&DacAction::WriteAndUpdate(DacPair::new(0x8000, 0x2000)))
    );
    // Inputs written on the SM2 event.
    assert_eq!(r.esc.master_read_inputs(), vec![0x00, 0x40, 0xFF, 0x7F]);
}

#[test]
fn invalid_mailbox_configuration_is_0x0016() {
    for (n, start, len, control, enable) in [
        (0u8, 0x1008u16, 128u16, 0x26u8, true),
        (0, MBX_OUT, 64, 0x26, true),
        (1, MBX_IN, 128, 0x26, true),
        (1, MBX_IN, 128, 0x22, false),
    ] {
        let mut r = Rig::new();
        r.mailbox_sms();
        r.esc.master_sm(n, start, len, control, enable);
        assert_eq!(r.request(0x02), (0x11, 0x0016));
        assert_eq!(r.app.state(), AlState::Init);
        // Acknowledge and retry with the right configuration.
        r.mailbox_sms();
        assert_eq!(r.request(0x12), (0x02, 0));
    }
    // ECAT IRQ bit in the control byte is the master's choice.
    let mut r = Rig::new();
    r.mailbox_sms();
    r.esc.master_sm(0, MBX_OUT, 128, 0x36, true);
    assert_eq!(r.request(0x02), (0x02, 0));
}

#[test]
fn invalid_process_data_configuration_is_0x001d_0x001e() {
    let mut r = Rig::new();
    r.goto_preop();
    r.pd_sms(2, 4);
    assert_eq!(r.request(0x04), (0x12, 0x001D));
    r.pd_sms(4, 6);
    assert_eq!(r.request(0x14), (0x12, 0x001E));
    r.pd_sms(4, 4);
    r.esc.master_sm(2, 0x1200, 4, 0x64, true);
    assert_eq!(r.request(0x14), (0x12, 0x001D));
    r.pd_sms(4, 4);
    r.esc.master_sm(3, PD_IN, 4, 0x24, true); // wrong direction
    assert_eq!(r.request(0x14), (0x12, 0x001E));
    assert!(r.dac.is_empty());
    r.pd_sms(4, 4);
    assert_eq!(r.request(0x14), (0x04, 0));
}

#[test]
fn refused_transitions_and_unknown_states() {
    let mut r = Rig::new();
    assert_eq!(r.request(0x04), (0x11, 0x0011));
    assert_eq!(r.request(0x18), (0x11, 0x0011)); // ack + I->O
    assert_eq!(r.request(0x13), (0x11, 0x0013)); // ack + BOOT
    assert_eq!(r.request(0x15), (0x11, 0x0012)); // ack + unknown 5
    r.mailbox_sms();
    assert_eq!(r.request(0x12), (0x02, 0));
    assert_eq!(r.request(0x08), (0x12, 0x0011)); // P->O
                                                 // ID request.
    assert_eq!(r.request(0x32), (0x22, 0x0042));
    assert_eq!(r.request(0x02), (0x02, 0));
}

/// INIT -> BOOT on the bootstrap mailbox: the application keeps INIT and asks for the
/// bootloader; with the standard mailbox configured instead it refuses with 0x0015; from
/// PREOP it is a forbidden transition (0x0011).
#[test]
fn init_to_boot_enters_the_bootloader_on_the_bootstrap_mailbox_only() {
    let mut r = Rig::with(boot_config());
    r.mailbox_sms();
    r.esc.master_al_control(0x03);
    let out = r
        .app
        .on_pdi_irq(&mut r.esc.driver(), &r.stage, 1_000)
        .unwrap();
    assert!(
        !out.enter_bootloader,
        "the standard mailbox is not the bootstrap one"
    );
    assert_eq!(r.esc.al_status(), (0x11, 0x0015));

    r.esc.master_sm(0, BOOT_OUT, BOOT_LEN, 0x26, true);
    r.esc.master_sm(1, BOOT_IN, BOOT_LEN, 0x22, true);
    r.esc.master_al_control(0x13);
    let out = r
        .app
        .on_pdi_irq(&mut r.esc.driver(), &r.stage, 2_000)
        .unwrap();
    assert!(out.enter_bootloader);
    assert_eq!(
        r.esc.al_status(),
        (0x01, 0),
        "INIT until the bootloader reports BOOT"
    );
    assert_eq!(r.app.state(), AlState::Init);

    let mut r = Rig::with(boot_config());
    r.goto_preop();
    assert_eq!(r.request(0x03), (0x12, 0x0011));
}

/// FoE in PREOP: a firmware file is "bootstrap only" (0x8008), any other name "not found";
/// the answers share the mailbox counter with CoE.
#[test]
fn foe_outside_boot_is_answered() {
    let mut r = Rig::with(boot_config());
    r.goto_preop();
    let foe = |r: &mut Rig, name: &[u8]| {
        r.counter = r.counter % 7 + 1;
        let mut f = vec![6 + name.len() as u8, 0, 0, 0, 0x00, 0x04 | r.counter << 4];
        f.extend_from_slice(&[0x02, 0x00, 0, 0, 0, 0]);
        f.extend_from_slice(name);
        assert!(r.esc.master_write_mailbox(&f));
        r.irq();
        r.esc.master_read_mailbox().expect("reply")
    };
    let reply = foe(&mut r, b"analog-io.efw");
    assert_eq!(reply[5] & 0x0F, 0x04, "an FoE answer");
    assert_eq!(reply[5] >> 4, r.counter);
    assert_eq!(&reply[6..12], &[0x05, 0x00, 0x08, 0x80, 0x00, 0x00]);
    assert_eq!(&reply[12..6 + usize::from(reply[0])], b"in BOOT only");
    let reply = foe(&mut r, b"notes.txt");
    assert_eq!(&reply[6..12], &[0x05, 0x00, 0x01, 0x80, 0x00, 0x00]);
}

#[test]
fn mailbox_upload_busy_sm1_and_repeat() {
    let mut r = Rig::new();
    r.goto_preop();
    assert_eq!(r.upload(0x1000, 0), Ok(vec![0x91, 0x01, 0x0C, 0x00]));
    // SM1 still full: the next reply waits.
    let f = [
        10u8,
        0,
        0,
        0,
        0,
        0x03 | 0x50,
        0x00,
        0x20,
        0x40,
        0x01,
        0x10,
        0,
        0,
        0,
        0,
        0,
    ];
    assert!(r.esc.master_write_mailbox(&f));
    r.irq();
    let first = r.esc.master_read_mailbox().unwrap();
    assert_eq!(first[8], 0x4F); // 0x1001 u8
                                // Repeat request: the same frame again, ack mirrored.
    r.esc.master_repeat_request();
    r.irq();
    let again = r.esc.master_read_mailbox().unwrap();
    assert_eq!(again, first);
    assert_eq!(r.esc.sm(1).pdi_control & 0x02, r.esc.sm(1).activate & 0x02);
    assert_eq!(r.app.mailbox().repeats(), 1);
    // Pending reply when SM1 is full.
    let f2 = [
        10u8,
        0,
        0,
        0,
        0,
        0x03 | 0x60,
        0x00,
        0x20,
        0x40,
        0x00,
        0x10,
        0,
        0,
        0,
        0,
        0,
    ];
    assert!(r.esc.master_write_mailbox(&f2));
    r.irq();
    assert!(!r.app.mailbox().reply_pending());
    let f3 = [
        10u8,
        0,
        0,
        0,
        0,
        0x03 | 0x70,
        0x00,
        0x20,
        0x40,
        0x01,
        0x10,
        0,
        0,
        0,
        0,
        0,
    ];
    assert!(r.esc.master_write_mailbox(&f3));
    r.irq(); // SM1 full: request stays in SM0
    assert!(!r.esc.master_write_mailbox(&f3), "SM0 still full");
    assert_eq!(r.esc.master_read_mailbox().unwrap()[8], 0x43);
    r.irq();
    assert_eq!(r.esc.master_read_mailbox().unwrap()[8], 0x4F);
}

#[test]
fn pdo_configuration_rules() {
    let mut r = Rig::new();
    r.goto_preop();
    // Mapping a non-mappable object: 0x06040041.
    assert_eq!(r.download(0x1600, 0, &[0]), Ok(()));
    assert_eq!(
        r.download(0x1600, 1, &0x1000_0020u32.to_le_bytes()),
        Err(0x0604_0041)
    );
    // One AO only: SM2 is then 2 bytes.
    assert_eq!(r.download(0x1600, 1, &0x6411_0110u32.to_le_bytes()), Ok(()));
    assert_eq!(r.download(0x1600, 0, &[1]), Ok(()));
    r.pd_sms(4, 4);
    assert_eq!(r.request(0x04), (0x12, 0x001D));
    r.pd_sms(2, 4);
    assert_eq!(r.request(0x14), (0x04, 0));
    // Not in SAFEOP.
    assert_eq!(r.download(0x1600, 0, &[0]), Err(0x0800_0022));
    assert_eq!(
        r.upload(0x1600, 1),
        Ok(0x6411_0110u32.to_le_bytes().to_vec())
    );
}

#[test]
fn watchdog_faults_outputs_and_goes_to_safeop() {
    let mut r = Rig::new();
    r.goto_op();
    assert_eq!(r.download(0x6444, 1, &0x1000i32.to_le_bytes()), Ok(()));
    assert_eq!(r.download(0x6443, 2, &[0]), Ok(())); // channel B keeps
    assert_eq!(
        r.download(0x6444, 2, &(-1i32).to_le_bytes()),
        Err(0x0609_0030)
    );
    r.outputs(0x100, 0x200);
    r.esc.expire_watchdog();
    r.irq();
    assert_eq!(r.esc.al_status(), (0x14, 0x001B));
    assert_eq!(
        r.dac.last(),
        Some(&DacAction::WriteAndUpdate(DacPair::new(0x2000, 0x400)))
    );
    assert_eq!(r.app.application().diag.register(), 0x11);
    // It enters the error history (0x1003): code, 0x1001, first data byte.
    let history = r.app.application().diag.history;
    assert_eq!((history.len(), history.get(1)), (1, Ok(0x0011_8250)));
    // The Emergency goes out through SM1.
    r.poll();
    let emcy = r.esc.master_read_mailbox().unwrap();
    assert_eq!(emcy[5] & 0x0F, 3);
    assert_eq!(u16::from_le_bytes([emcy[6], emcy[7]]) >> 12, 1);
    assert_eq!(u16::from_le_bytes([emcy[8], emcy[9]]), 0x8250);
    // Outputs in SAFEOP are not applied; back to OP only fresh data drive the DAC.
    let n = r.dac.len();
    r.outputs(0x300, 0x300);
    assert_eq!(r.dac.len(), n);
    assert_eq!(r.request(0x18), (0x08, 0));
    assert_eq!(r.app.application().diag.register(), 0);
    assert_eq!(
        r.app.application().diag.history.len(),
        1,
        "the error reset is no error"
    );
    assert_eq!(r.dac.len(), n);
    r.outputs(0x10, 0x20);
    assert_eq!(
        r.dac.last(),
        Some(&DacAction::WriteAndUpdate(DacPair::new(0x20, 0x40)))
    );
}

/// 0x1C33:06 (calc and copy, inputs) follows the assigned TxPDOs: the one-value inputs'
/// figure, plus the SM3 write of every byte the oversampling blocks add.
#[test]
fn input_calc_copy_time_follows_the_assigned_image() {
    use crate::products::analog_io::sync::{INPUT_CALC_COPY_NS, INPUT_COPY_NS_PER_BYTE};
    use coe_core::od::ObjectAccess;
    let mut io = AnalogIo::<AnalogFigures>::new(&super::od::OD, super::process_data());
    let mut calc_copy = || {
        let mut buf = [0u8; 4];
        assert_eq!(io.read(0x1C33, 6, &mut buf), Ok(4));
        u32::from_le_bytes(buf)
    };
    assert_eq!(calc_copy(), INPUT_CALC_COPY_NS);
    let mut pdos = vec![0x1A10u16, 0x1A11];
    pdos.extend(0x1A20..0x1A28);
    let mut write = |sub: u8, data: &[u8]| io.write(0x1C13, sub, data, AlState::PreOp);
    assert_eq!(write(0, &[0]), Ok(()));
    for (sub, pdo) in (1u8..).zip(&pdos) {
        assert_eq!(write(sub, &pdo.to_le_bytes()), Ok(()));
    }
    assert_eq!(write(0, &[pdos.len() as u8]), Ok(()));
    // Status and time (14 B) and 8 x 64 B of samples: 510 B more than the 16 B covered.
    let mut buf = [0u8; 4];
    assert_eq!(io.read(0x1C33, 6, &mut buf), Ok(4));
    assert_eq!(
        u32::from_le_bytes(buf),
        INPUT_CALC_COPY_NS + 510 * INPUT_COPY_NS_PER_BYTE
    );
}

/// SM-synchronous mode with a cycle time set by the master (TwinCAT writes 0x1C32:02): a
/// master that stops is no sync error; the SM watchdog reports it (0x001B), as in the SSC.
#[test]
fn sm_sync_stopped_master_is_a_watchdog_not_a_sync_error() {
    let mut r = Rig::new();
    r.goto_preop();
    r.pd_sms(4, 4);
    assert_eq!(r.download(0x1C32, 2, &1_000_000u32.to_le_bytes()), Ok(()));
    assert_eq!(r.request(0x04), (0x04, 0));
    assert_eq!(r.request(0x08), (0x08, 0));
    r.outputs(0x100, 0x200);
    // 20 ms without outputs: 20 cycles.
    for _ in 0..2_000 {
        r.poll();
    }
    assert_eq!(r.esc.al_status(), (0x08, 0));
    assert_eq!(r.upload(0x1C32, 0x0B), Ok(vec![0, 0]));
    r.esc.expire_watchdog();
    r.irq();
    assert_eq!(r.esc.al_status(), (0x14, 0x001B));
}

#[test]
fn op_to_safeop_applies_fault_values() {
    let mut r = Rig::new();
    r.goto_op();
    r.outputs(0x100, 0x200);
    assert_eq!(r.request(0x04), (0x04, 0));
    assert_eq!(
        r.dac.last(),
        Some(&DacAction::WriteAndUpdate(DacPair::new(0, 0)))
    );
    // OP -> PREOP from OP as well.
    assert_eq!(r.request(0x08), (0x08, 0));
    r.outputs(0x100, 0x200);
    assert_eq!(r.request(0x02), (0x02, 0));
    assert_eq!(
        r.dac.last().and_then(DacAction::pair),
        Some(DacPair::new(0, 0))
    );
}

#[test]
fn dc_mode_enforced_at_safeop_and_latched_at_sync0() {
    let mut r = Rig::new();
    r.goto_preop();
    r.pd_sms(4, 4);
    assert_eq!(r.download(0x1C32, 1, &2u16.to_le_bytes()), Ok(()));
    assert_eq!(r.request(0x04), (0x12, 0x0030));
    r.esc.master_dc(0x03, 10_000);
    assert_eq!(r.request(0x14), (0x12, 0x0035));
    r.esc.master_dc(0x03, 1_000_000);
    assert_eq!(r.request(0x14), (0x04, 0));
    assert_eq!(r.app.sync().mode(), SyncMode::DcSync0);
    assert_eq!(r.request(0x08), (0x08, 0));
    // Outputs wait for SYNC0.
    r.outputs(0x100, 0x100);
    assert!(r.dac.is_empty());
    assert_eq!(
        r.sync0(),
        DacAction::WriteAndUpdate(DacPair::new(0x200, 0x200))
    );
    // SYNC0 with no fresh outputs keeps and counts.
    assert_eq!(r.sync0(), DacAction::Keep);
    assert_eq!(r.stage.sync0_without_outputs(), 1);
    assert_eq!(r.upload(0x1C32, 0x0B), Ok(vec![1, 0]));
    // Second miss: sync error counter 6 > 4 -> SAFEOP + 0x001A, fault values.
    assert_eq!(r.sync0(), DacAction::Keep);
    assert_eq!(r.esc.al_status(), (0x14, 0x001A));
    assert_eq!(
        r.dac.last(),
        Some(&DacAction::WriteAndUpdate(DacPair::new(0, 0)))
    );
}

#[test]
fn dc_without_explicit_mode_follows_the_esc() {
    let mut r = Rig::new();
    r.goto_preop();
    r.pd_sms(4, 4);
    r.esc.master_dc(0x03, 1_000_000);
    assert_eq!(r.request(0x04), (0x04, 0));
    assert_eq!(r.app.sync().mode(), SyncMode::DcSync0);
    // And an explicit SM-sync request with SYNC0 active is refused.
    let mut r = Rig::new();
    r.goto_preop();
    r.pd_sms(4, 4);
    r.esc.master_dc(0x03, 1_000_000);
    assert_eq!(r.download(0x1C32, 1, &1u16.to_le_bytes()), Ok(()));
    assert_eq!(r.request(0x04), (0x12, 0x0030));
}

#[test]
fn free_run_needs_three_buffer_sm2() {
    let mut r = Rig::new();
    r.goto_preop();
    assert_eq!(r.download(0x1C32, 1, &0u16.to_le_bytes()), Ok(()));
    r.pd_sms(4, 4);
    r.esc.master_sm(2, PD_OUT, 4, 0x66, true); // mailbox (1-buffer) mode
    assert_eq!(r.request(0x04), (0x12, 0x0029));
    assert_eq!(r.download(0x1C32, 1, &3u16.to_le_bytes()), Err(0x0609_0030));
}

#[test]
fn sdo_ao_write_in_op_drives_outputs() {
    let mut r = Rig::new();
    r.goto_preop();
    // Unmap AO so SDO may write it in OP.
    assert_eq!(r.download(0x1C12, 0, &[0]), Ok(()));
    r.pd_sms(0, 4);
    r.esc.master_sm(2, PD_OUT, 0, 0x64, false);
    assert_eq!(r.request(0x04), (0x04, 0));
    assert_eq!(r.request(0x08), (0x08, 0));
    assert_eq!(r.download(0x6411, 1, &0x10i16.to_le_bytes()), Ok(()));
    assert_eq!(
        r.dac.last(),
        Some(&DacAction::WriteAndUpdate(DacPair::new(0x20, 0)))
    );
    assert_eq!(r.upload(0x6411, 1), Ok(vec![0x10, 0]));
}

#[test]
fn bus_errors_are_reported_not_panics() {
    let mut r = Rig::new();
    r.esc.master_al_control(0x02);
    r.esc.fail_next = true;
    assert!(r.app.on_pdi_irq(&mut r.esc.driver(), &r.stage, 0).is_err());
    // The event is still pending and handled next time.
    r.mailbox_sms();
    r.irq();
    assert_eq!(r.esc.al_status(), (0x02, 0));
}

/// DC OP: a cycle is the event bits, the SM2 read and the SM3 write; the mailbox registers
/// are read only on mailbox events, for waiting work, or by the periodic safety service.
#[test]
fn dc_cycle_reads_no_mailbox_registers() {
    let mut r = Rig::new();
    r.goto_preop();
    r.pd_sms(4, 4);
    assert_eq!(r.download(0x1C32, 1, &2u16.to_le_bytes()), Ok(()));
    r.esc.master_dc(0x03, 1_000_000);
    assert_eq!(r.request(0x04), (0x04, 0));
    assert_eq!(r.request(0x08), (0x08, 0));
    let (reads, sm_reads, writes) = (r.esc.reads, r.esc.sm_register_reads, r.esc.writes);
    for k in 1..=5i16 {
        r.outputs(0x100 * k, 0x80 * k);
        r.sync0();
    }
    assert_eq!(r.esc.sm_register_reads, sm_reads);
    // Per cycle: the event bits (IRQ), SM2 and, the outputs having changed, SM2 again to
    // confirm them (a 1 ms cycle has room for it); one write: SM3.
    assert_eq!(r.esc.reads - reads, 5 * 3);
    assert_eq!(r.esc.writes - writes, 5);
    // The mailbox still answers in OP (SM0 event), and the reply leaves SM1 busy until the
    // master has read it.
    assert_eq!(r.upload(0x1C32, 0x0B), Ok(vec![0, 0]));
    assert!(r.app.mailbox().sm1_busy());
    // The master has read it: the event bits of the next SM3 write tell, without a
    // register read.
    let sm_reads = r.esc.sm_register_reads;
    r.sync0();
    assert!(!r.app.mailbox().sm1_busy());
    assert_eq!(r.esc.sm_register_reads, sm_reads);
    assert_eq!(r.esc.al_status(), (0x08, 0));
    // The periodic safety service reads the registers even without events (the mailbox
    // task: the PDI error counter, then the registers).
    r.now += u64::from(crate::stacks::ethercat::mailbox::SAFETY_SERVICE_MS) * 1_000_000;
    r.poll();
    assert!(r.esc.sm_register_reads > sm_reads);
}

impl Rig {
    /// PREOP -> OP in DC mode with 1 ms SYNC0 cycles, no sync error however many SM events
    /// are missed (what a test of the master stopping looks at is then the mailbox).
    fn goto_op_dc_1ms(&mut self) {
        self.goto_preop();
        self.pd_sms(4, 4);
        assert_eq!(self.download(0x1C32, 1, &2u16.to_le_bytes()), Ok(()));
        assert_eq!(self.download(0x10F1, 2, &u16::MAX.to_le_bytes()), Ok(()));
        self.esc.master_dc(0x03, 1_000_000);
        assert_eq!(self.request(0x04), (0x04, 0));
        assert_eq!(self.request(0x08), (0x08, 0));
    }

    /// 1 ms DC cycles (outputs, then the edge and the poll after it) until the safety
    /// service is due: `now` is then past it, before the next cycle's outputs.
    fn dc_cycles_until_the_safety_service_is_due(&mut self) {
        for k in 1..200i16 {
            self.now += 950_000;
            // Due now or within this cycle's steps (each rig call takes 10 us).
            if self.app.safety_service_due(self.now + 100_000) {
                self.now += 100_000;
                return;
            }
            self.outputs(0x10 * k, 0x08 * k);
            self.sync0();
        }
        panic!("the safety service never came due");
    }
}

/// In DC mode with no output events (the master stopped sending frames), the poll asks
/// for the safety service itself once it is a whole period overdue.
#[test]
fn dc_safety_service_without_output_events_comes_from_the_poll() {
    let mut r = Rig::new();
    r.goto_op_dc_1ms();
    r.dc_cycles_until_the_safety_service_is_due();
    let Rig {
        mut esc,
        app,
        stage,
        now,
        ..
    } = r;
    let mut task = PdiTask::new(app);
    let poll = Wake {
        edge: false,
        line_asserted: false,
        poll: true,
        pdi_ready: true,
    };
    let mut run = |at: u64| task.run(&mut esc.driver(), &stage, at, poll, || false, |_| {});
    assert!(!run(now + 5_000).serve_mailbox, "left to the output event");
    let period = u64::from(SAFETY_SERVICE_MS) * 1_000_000;
    assert!(
        run(now + period + 5_000).serve_mailbox,
        "overdue: the poll asks"
    );
}

/// In DC mode in OP the safety service (the PDI error counter and the mailbox registers)
/// is the mailbox task's: the output event that finds it due asks the mailbox task (so its
/// steps start after the outputs are preloaded, not just before the next frame) and reads
/// none of its registers itself; the mailbox task reads them, one step per access.
#[test]
fn dc_safety_service_is_the_mailbox_tasks() {
    let mut r = Rig::new();
    r.goto_op_dc_1ms();
    r.dc_cycles_until_the_safety_service_is_due();
    let Rig {
        mut esc,
        app,
        stage,
        now,
        ..
    } = r;
    let sm_reads = esc.sm_register_reads;
    let mut task = PdiTask::new(app);
    let run =
        |task: &mut PdiTask<AnalogIo<AnalogFigures>>, esc: &mut FakeEsc, at: u64, wake: Wake| {
            task.run(&mut esc.driver(), &stage, at, wake, || false, |_| {})
        };
    let irq = Wake {
        edge: true,
        line_asserted: true,
        poll: false,
        pdi_ready: true,
    };
    // The poll after an edge leaves it to the next output event.
    let poll = Wake {
        edge: false,
        line_asserted: false,
        poll: true,
        pdi_ready: true,
    };
    let done = run(&mut task, &mut esc, now + 5_000, poll);
    assert!(!done.serve_mailbox, "left to the output event");
    assert!(task.app().safety_service_due(now + 5_000));
    esc.master_write_outputs(&[0x00, 0x7F, 0x00, 0x3F]);
    let done = run(&mut task, &mut esc, now + 10_000, irq);
    assert!(done.preload_outputs && done.serve_mailbox);
    assert_eq!(stage.staged().1, DacPair::new(0xFE00, 0x7E00), "staged");
    assert_eq!(esc.sm_register_reads, sm_reads, "not read by the PDI task");
    assert!(!task.app().safety_service_due(now + 20_000), "re-armed");
    let reads = esc.reads;
    let mut steps = 0;
    while task
        .mailbox_step(&mut esc.driver(), &stage, now + 20_000)
        .more
    {
        steps += 1;
    }
    assert!(esc.sm_register_reads > sm_reads, "read by the mailbox task");
    assert!(
        esc.reads - reads >= 2,
        "the PDI error counter and the registers"
    );
    assert!(steps >= 1, "one access per step");
    assert_eq!(esc.al_status(), (0x08, 0));
}

/// The periodic safety service belongs to PREOP and up: an SM activation in INIT (the
/// master configuring the mailbox) reads the mailbox registers but arms no service, and back
/// in INIT none is due however long the module waits.
#[test]
fn no_safety_service_is_due_in_init() {
    let mut r = Rig::new();
    r.mailbox_sms();
    r.esc.raise(AlEvents::SM_ACTIVATION);
    r.irq();
    assert!(!r.app.safety_service_due(r.now + 1_000_000_000));
    r.goto_preop();
    let period = u64::from(SAFETY_SERVICE_MS) * 1_000_000;
    assert!(!r.app.safety_service_due(r.now));
    assert!(r.app.safety_service_due(r.now + period));
    assert_eq!(r.request(0x01), (0x01, 0));
    assert!(!r.app.safety_service_due(r.now + 1_000_000_000));
}

/// The AL event mask is worked out again only when what it is made of may have changed: an
/// Emergency raised by the outputs while SM1 holds an unread reply must still enable the
/// SM1 event, or it would wait for the safety service.
#[test]
fn an_emergency_while_sm1_is_busy_enables_the_sm1_event() {
    let mut r = Rig::new();
    r.goto_op();
    // An upload of 0x1000 whose reply the master leaves in SM1.
    let request = [
        10u8, 0, 0, 0, 0, 0x13, 0x00, 0x20, 0x40, 0x00, 0x10, 0, 0, 0, 0, 0,
    ];
    assert!(r.esc.master_write_mailbox(&request));
    r.irq();
    assert!(r.app.mailbox().sm1_busy());
    assert!(!r.esc.event_mask().contains(AlEvents::SM1));
    // A negative AO value: out of range, an Emergency to send.
    r.outputs(-1, 0);
    assert!(r.esc.event_mask().contains(AlEvents::SM1));
    assert_eq!(r.esc.master_read_mailbox().unwrap()[8], 0x43);
    r.irq();
    let emergency = r
        .esc
        .master_read_mailbox()
        .expect("the Emergency follows the reply");
    assert_eq!(emergency[7] >> 4, 0x1, "CoE service 1: Emergency");
    r.irq();
    assert!(!r.esc.event_mask().contains(AlEvents::SM1));
}

/// An SDO exchange on the mailbox events reads no SyncManager registers: SM0 full and SM1
/// free come from the event bits, start and length from INIT -> PREOP; the SM activation
/// event (the master changed a SyncManager) reads them again.
#[test]
fn sdo_exchanges_read_no_sync_manager_registers() {
    let mut r = Rig::new();
    r.goto_preop();
    let sm_reads = r.esc.sm_register_reads;
    assert_eq!(r.upload(0x1000, 0), Ok(vec![0x91, 0x01, 0x0C, 0x00]));
    assert_eq!(r.download(0x6443, 1, &[1]), Ok(()));
    assert_eq!(r.upload(0x6443, 1), Ok(vec![1]));
    assert_eq!(r.esc.sm_register_reads, sm_reads);
    // The master moves SM1 (disabled, new length, enabled: the activation event).
    r.esc.master_sm(1, MBX_IN, 64, 0x22, true);
    r.esc.raise(AlEvents::SM_ACTIVATION);
    r.irq();
    assert!(r.esc.sm_register_reads > sm_reads);
    let reply = r.sdo(0x40, 0x1000, 0, [0; 4]);
    assert_eq!(reply.len(), 64);
    assert_eq!(reply[8], 0x43);
}

/// Without an IRQ the background poll still finds a request: it samples the event bits
/// itself every EVENT_SAMPLE_MS when no inputs write brought them.
#[test]
fn background_poll_samples_the_events_every_interval() {
    let mut r = Rig::new();
    r.goto_preop();
    r.poll();
    let f = [
        10u8, 0, 0, 0, 0, 0x13, 0x00, 0x20, 0x40, 0x00, 0x10, 0, 0, 0, 0, 0,
    ];
    assert!(r.esc.master_write_mailbox(&f));
    let reads = r.esc.reads;
    r.poll();
    assert_eq!(r.esc.reads, reads, "no access within the sample interval");
    assert!(r.esc.master_read_mailbox().is_none());
    r.now += u64::from(crate::stacks::ethercat::mailbox::EVENT_SAMPLE_MS) * 1_000_000;
    r.poll();
    assert_eq!(r.esc.master_read_mailbox().unwrap()[8], 0x43);
}

/// Outputs read wrong on the SPI (a flipped bit) never reach the DAC: changed outputs are
/// taken when two reads agree; unchanged ones cost no second read.
#[test]
fn a_corrupted_output_read_never_reaches_the_dac() {
    let mut r = Rig::new();
    r.goto_op();
    r.outputs(0x1000, 0x2000);
    assert_eq!(r.stage.staged().1, DacPair::new(0x2000, 0x4000));
    // AO1's high byte read with bit 6 flipped (0x10 -> 0x50).
    r.esc.corrupt_next_read = Some((PD_OUT, 1, 0x40, 1));
    r.outputs(0x1100, 0x2000);
    assert_eq!(r.esc.corrupt_next_read, None, "the fault hit");
    for a in &r.dac {
        assert_ne!(
            a.pair().map(|p| p.a),
            Some(0x5100 << 1),
            "corrupted value applied"
        );
    }
    assert_eq!(
        r.dac.last(),
        Some(&DacAction::WriteAndUpdate(DacPair::new(0x2200, 0x4000)))
    );
    // The same outputs again: one read.
    let reads = r.esc.reads;
    r.outputs(0x1100, 0x2000);
    assert_eq!(r.esc.reads - reads, 2, "events and SM2");
}

/// Output reads that never agree are dropped (the outputs stay as they were) and reported
/// with the ESC's PDI error counter by an Emergency 0x5000 in the safety service.
#[test]
fn unstable_output_reads_are_dropped_and_reported() {
    let mut r = Rig::new();
    r.goto_op();
    r.outputs(0x1000, 0x2000);
    let applied = r.dac.len();
    // All three reads of new outputs corrupted, each differently.
    r.esc.corrupt_next_read = Some((PD_OUT, 0, 0x01, 3));
    r.outputs(0x3000, 0x2000);
    assert_eq!(r.esc.corrupt_next_read, None, "three reads hit");
    assert_eq!(r.dac.len(), applied, "nothing applied");
    assert_eq!(
        r.stage.staged().1,
        DacPair::new(0x2000, 0x4000),
        "still the last outputs"
    );
    // The ESC counted errors of its own as well; the safety service reports both.
    r.esc.mem[usize::from(Register::PdiErrorCounter.addr())] = 3;
    r.now += u64::from(crate::stacks::ethercat::mailbox::SAFETY_SERVICE_MS) * 1_000_000;
    // The counter, then the registers, which send the Emergency.
    r.poll();
    r.poll();
    let frame = r.esc.master_read_mailbox().expect("an Emergency");
    assert_eq!(&frame[6..8], &[0x00, 0x10], "CoE Emergency");
    assert_eq!(u16::from_le_bytes([frame[8], frame[9]]), 0x5000);
    assert_eq!(frame[11], 3, "the ESC's PDI error counter");
    assert!(
        u16::from_le_bytes([frame[13], frame[14]]) >= 1,
        "dropped reads"
    );
}

/// Below `CONFIRM_OUTPUTS_MIN_CYCLE_NS` there is no room for the confirming read: changed
/// outputs are read once; from it on, twice. The shortest DC cycle the module accepts reads
/// them as its side of that threshold says.
#[test]
fn the_shortest_dc_cycle_confirms_outputs_as_its_threshold_says() {
    let mut r = Rig::new();
    r.goto_preop();
    r.pd_sms(4, 4);
    r.esc
        .master_dc(0x03, crate::products::analog_io::sync::MIN_CYCLE_TIME_NS);
    assert_eq!(r.request(0x04), (0x04, 0));
    assert_eq!(r.request(0x08), (0x08, 0));
    let reads = r.esc.reads;
    for k in 1..=5i16 {
        r.outputs(0x100 * k, 0x80 * k);
        r.sync0();
    }
    let min = crate::products::analog_io::sync::MIN_CYCLE_TIME_NS;
    let confirmed = min >= crate::products::analog_io::sync::CONFIRM_OUTPUTS_MIN_CYCLE_NS;
    let per_cycle = if confirmed { 3 } else { 2 };
    assert_eq!(
        r.esc.reads - reads,
        5 * per_cycle,
        "events and SM2 (twice when confirmed)"
    );
}

/// AL status written wrong on the SPI (a flipped bit) is read back and written again: the
/// master sees the state the slave is in. AL control read wrong is read again.
#[test]
fn al_status_is_read_back_and_al_control_confirmed() {
    let mut r = Rig::new();
    r.mailbox_sms();
    r.esc.corrupt_next_write = Some((Register::AlStatus.addr(), 0, 0x04));
    assert_eq!(r.request(0x02), (0x02, 0));
    assert_eq!(r.esc.corrupt_next_write, None, "the fault hit");
    // AL control SAFEOP (0x04) read as 0x0C (undefined): no refusal.
    r.pd_sms(4, 4);
    r.esc.corrupt_next_read = Some((Register::AlControl.addr(), 0, 0x08, 1));
    assert_eq!(r.request(0x04), (0x04, 0));
    assert_eq!(r.esc.corrupt_next_read, None, "the fault hit");
}

mod op_modes;
mod output_blocks;
