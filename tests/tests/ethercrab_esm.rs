//! ETHERCRAB SYSTEM TEST: a real master (ethercrab 0.7.1) drives the virtual board from
//! INIT to OP and exchanges process data.
//!
//! The PDI side is a test-local [`MinimalSlaveCpu`]: it acknowledges AL control by
//! writing AL status through the SPI front end, moves SM2 outputs out and SM3 inputs in,
//! and configures nothing else. The SII image is generated (`coe_core::sii`) from a test
//! device description below: no mailbox, one RxPDO and one TxPDO.
//!
//! Each scenario saves its capture; the tests named `*_decodes_in_tshark` run it again and
//! decode the capture with tshark (ignored unless run explicitly, as `cargo xtask test`
//! does: they need tshark).

use coe_core::device::{
    CoeDetails, DcDesc, DeviceDescription, EepromDesc, FmmuUsage, Identity, MailboxDesc,
    MailboxProtocols, MemoryWindow, Names, PortType, SmRole, SyncManagerDesc,
};
use coe_core::od::{Access, DataType, EntryDesc, ObjectDesc, ObjectDictionary, Value};
use ethercrab::{std::ethercat_now, MainDevice, MainDeviceConfig, PduStorage};
use futures_lite::future::{block_on, or};
use std::cell::RefCell;
use std::path::{Path, PathBuf};
use std::rc::Rc;
use std::time::Duration;
use virtual_board::capture_tests;
use virtual_board::models::esc::regs;
use virtual_board::models::spi::EscSpi;
use virtual_board::rig::board::{BoardConfig, BoardIo, PdiCpu, VirtualBoard};
use virtual_board::rig::master::{in_process_timeouts, tx_rx_task};
use virtual_board::tools::sim::firmware_device::sii_image;

use embedded_hal::spi::{Operation, SpiDevice};

/// Reads `n` bytes with command 3 (wait byte, 0xFF termination), 2-byte addressing.
fn spi_read(spi: &mut EscSpi, addr: u16, n: usize) -> (u16, Vec<u8>) {
    let hdr = [(addr >> 5) as u8, ((addr & 0x1F) << 3) as u8 | 0x03, 0xFF];
    let mut ev = [0u8; 3];
    let mut mosi = vec![0u8; n];
    mosi[n - 1] = 0xFF;
    let mut data = vec![0u8; n];
    spi.transaction(&mut [
        Operation::Transfer(&mut ev, &hdr),
        Operation::Transfer(&mut data, &mosi),
    ])
    .unwrap();
    (u16::from_le_bytes([ev[0], ev[1]]), data)
}

fn spi_write(spi: &mut EscSpi, addr: u16, data: &[u8]) {
    let hdr = [(addr >> 5) as u8, ((addr & 0x1F) << 3) as u8 | 0x04];
    spi.transaction(&mut [Operation::Write(&hdr), Operation::Write(data)])
        .unwrap();
}

#[derive(Default)]
struct Shared {
    /// Last SM2 (outputs) buffer read through SPI.
    outputs: Vec<[u8; 2]>,
    /// Value the CPU writes into SM3 (inputs).
    inputs: [u8; 2],
    /// AL states acknowledged.
    states: Vec<u8>,
}

/// Test-only PDI responder: acknowledges AL control, moves SM2/SM3 buffers.
struct MinimalSlaveCpu {
    shared: Rc<RefCell<Shared>>,
}

impl PdiCpu for MinimalSlaveCpu {
    fn on_irq(&mut self, io: &mut BoardIo) {
        let spi = &mut io.esc;
        // The event bits arrive during the address phase of any access.
        let (events, _) = spi_read(spi, regs::AL_EVENT_REQUEST, 4);
        if events & 0x0001 != 0 {
            let (_, ctl) = spi_read(spi, regs::AL_CONTROL, 2);
            let state = ctl[0] & 0x0F;
            spi_write(spi, regs::AL_STATUS_CODE, &[0, 0]);
            spi_write(spi, regs::AL_STATUS, &[state, 0]);
            self.shared.borrow_mut().states.push(state);
        }
        if events & (1 << (8 + 2)) != 0 {
            let (_, out) = spi_read(spi, 0x1100, 2);
            self.shared.borrow_mut().outputs.push([out[0], out[1]]);
        }
        if events & (1 << (8 + 3)) != 0 {
            let inputs = self.shared.borrow().inputs;
            spi_write(spi, 0x1180, &inputs);
        }
        if events & !0x0D01 != 0 {
            // Anything else (activation changes, ...): not handled by this responder;
            // mask it so the level IRQ does not stay asserted.
            let (_, mask) = spi_read(spi, regs::AL_EVENT_MASK, 4);
            let m = u32::from_le_bytes(mask.try_into().unwrap()) & !(events as u32 & !0x0D01);
            spi_write(spi, regs::AL_EVENT_MASK, &m.to_le_bytes());
        }
    }

    fn poll(&mut self, io: &mut BoardIo) {
        // Keep SM3 filled even before the first read by the master.
        let s = io.esc.esc().borrow().peek_u8(regs::sm(3) + 6);
        if s & 1 != 0 && self.shared.borrow().states.last() == Some(&4) {
            let inputs = self.shared.borrow().inputs;
            spi_write(&mut io.esc, 0x1180, &inputs);
        }
    }
}

const U16: DataType = DataType::Unsigned16;
const U32: DataType = DataType::Unsigned32;
const I16: DataType = DataType::Integer16;
const RO: Access = Access::RO;

/// Product code of the test device (placeholder vendor 0: not an ETG vendor ID).
const PRODUCT_CODE: u32 = 0x0000_1234;

static OD: ObjectDictionary = ObjectDictionary::new(&[
    ObjectDesc::record(
        0x1018,
        "Identity",
        DataType::Identity,
        &[
            EntryDesc::count(4),
            EntryDesc::new(1, "Vendor ID", U32, RO).with_default(Value::Uint(0)),
            EntryDesc::new(2, "Product code", U32, RO)
                .with_default(Value::Uint(PRODUCT_CODE as u64)),
            EntryDesc::new(3, "Revision", U32, RO).with_default(Value::Uint(1)),
            EntryDesc::new(4, "Serial number", U32, RO).with_default(Value::Uint(42)),
        ],
    ),
    ObjectDesc::record(
        0x1600,
        "Outputs",
        DataType::PdoMapping,
        &[
            EntryDesc::count(1),
            EntryDesc::new(1, "Entry", U32, RO).with_default(Value::Uint(0x7000_0110)),
        ],
    ),
    ObjectDesc::record(
        0x1A00,
        "Inputs",
        DataType::PdoMapping,
        &[
            EntryDesc::count(1),
            EntryDesc::new(1, "Entry", U32, RO).with_default(Value::Uint(0x6000_0110)),
        ],
    ),
    ObjectDesc::array(
        0x1C12,
        "RxPDO assign",
        &[
            EntryDesc::count(1),
            EntryDesc::new(1, "Assign", U16, RO).with_default(Value::Uint(0x1600)),
        ],
    ),
    ObjectDesc::array(
        0x1C13,
        "TxPDO assign",
        &[
            EntryDesc::count(1),
            EntryDesc::new(1, "Assign", U16, RO).with_default(Value::Uint(0x1A00)),
        ],
    ),
    ObjectDesc::array(
        0x6000,
        "Input",
        &[
            EntryDesc::count(1),
            EntryDesc::new(1, "Input 1", I16, RO.tx_mappable()),
        ],
    ),
    ObjectDesc::array(
        0x7000,
        "Output",
        &[
            EntryDesc::count(1),
            EntryDesc::new(1, "Output 1", I16, Access::RW.rx_mappable()),
        ],
    ),
]);

/// No mailbox protocols, one 16-bit RxPDO on SM2 at 0x1100 and one 16-bit TxPDO on SM3 at
/// 0x1180; the mailbox SyncManagers exist but carry nothing.
static DEVICE: DeviceDescription = DeviceDescription {
    identity: Identity {
        vendor_id: 0,
        product_code: PRODUCT_CODE,
        revision: 1,
        serial_number: 42,
    },
    names: Names {
        vendor_name: "Test",
        device_name: "Virtual analog IO (test)",
        order_code: "Virtual analog IO",
        group_type: "Test",
        group_name: "Test",
        hardware_version: "",
        software_version: "",
    },
    od: &OD,
    sync_managers: &[
        SyncManagerDesc::new(SmRole::MailboxOut, 0x1000, 0x80, 0x26),
        SyncManagerDesc::new(SmRole::MailboxIn, 0x1080, 0x80, 0x22),
        SyncManagerDesc::new(SmRole::ProcessDataOut, 0x1100, 2, 0x64),
        SyncManagerDesc::new(SmRole::ProcessDataIn, 0x1180, 2, 0x20),
    ],
    fmmus: &[FmmuUsage::Outputs, FmmuUsage::Inputs],
    mailbox: MailboxDesc {
        protocols: MailboxProtocols(0),
        coe: CoeDetails(0),
        bootstrap: None,
    },
    dc: DcDesc {
        op_modes: &[],
        min_cycle_ns: 100_000,
        max_cycle_ns: 100_000_000,
    },
    pdi: firmware::platform::board::PDI,
    eeprom: EepromDesc {
        size_bytes: 2048,
        station_alias: 0,
        version: 1,
    },
    process_ram: MemoryWindow::new(0x1000, 0x2000),
    ports: [PortType::Mii, PortType::Mii, PortType::None, PortType::None],
    ebus_current_ma: 0,
};

type Storage = PduStorage<16, { PduStorage::element_size(1100) }>;

capture_tests!(
    ethercrab_init_to_op_with_process_data,
    ethercrab_init_to_op_capture_decodes_in_tshark,
    init_to_op_with_process_data,
    "ethercrab-esm"
);

/// INIT -> OP with process data; returns the capture, saved as `pcap`.
fn init_to_op_with_process_data(pcap: &str) -> PathBuf {
    let board = Rc::new(RefCell::new(VirtualBoard::new(BoardConfig::new(
        sii_image(&DEVICE).expect("SII image"),
    ))));
    let shared = Rc::new(RefCell::new(Shared {
        inputs: [0x34, 0x12],
        ..Default::default()
    }));
    board.borrow_mut().set_cpu(Box::new(MinimalSlaveCpu {
        shared: shared.clone(),
    }));

    let storage = Box::new(Storage::new());
    let (tx, rx, pdu_loop) = storage.try_split().expect("split once");
    let md = MainDevice::new(
        pdu_loop,
        in_process_timeouts(),
        MainDeviceConfig {
            dc_static_sync_iterations: 10,
            ..Default::default()
        },
    );

    block_on(or(
        async {
            let group = md
                .init_single_group::<2, 16>(ethercat_now)
                .await
                .expect("init");
            assert_eq!(group.len(), 1);
            let sd = group.subdevice(&md, 0).unwrap();
            // Read from the generated SII: order string, name string, identity.
            assert_eq!(sd.name(), DEVICE.names.order_code);
            assert_eq!(
                sd.description().await.unwrap().as_deref(),
                Some(DEVICE.names.device_name)
            );
            let id = sd.identity();
            assert_eq!(
                (id.vendor_id, id.product_id, id.revision, id.serial),
                (0, PRODUCT_CODE, 1, 42)
            );
            let group = group.into_op(&md).await.expect("PRE-OP -> OP");
            for i in 0..10u8 {
                {
                    let sd = group.subdevice(&md, 0).unwrap();
                    let mut o = sd.outputs_raw_mut();
                    o[0] = 0xA0 + i;
                    o[1] = 0x55;
                }
                group.tx_rx(&md).await.expect("tx_rx");
            }
            let sd = group.subdevice(&md, 0).unwrap();
            assert_eq!(&sd.inputs_raw()[..], &[0x34, 0x12]);
        },
        tx_rx_task(board.clone(), tx, rx),
    ));

    let s = shared.borrow();
    // INIT (ethercrab's reset BWR 0x0120 = 0x11), then PREOP, SAFEOP, OP.
    assert_eq!(s.states, vec![1, 2, 4, 8]);
    assert_eq!(s.outputs.last(), Some(&[0xA9, 0x55]));
    let b = board.borrow();
    assert_eq!(b.esc().borrow().peek_u8(regs::AL_STATUS), 8);
    let capture = b.pcap().unwrap();
    let path = Path::new(env!("CARGO_TARGET_TMPDIR")).join(pcap);
    capture.save(&path).unwrap();
    eprintln!("pcap: {} frames -> {}", capture.frames(), path.display());
    path
}

capture_tests!(
    ethercrab_dc_sync0_reaches_the_board,
    ethercrab_dc_capture_decodes_in_tshark,
    dc_sync0_reaches_the_board,
    "ethercrab-dc"
);

/// ethercrab's DC set-up (receive-time latch, offsets, static drift compensation with
/// FRMW, `configure_dc_sync`) makes the virtual ESC generate SYNC0 at the requested
/// period, delivered to the PDI-side CPU. Returns the capture, saved as `pcap`.
fn dc_sync0_reaches_the_board(pcap: &str) -> PathBuf {
    let board = Rc::new(RefCell::new(VirtualBoard::new(BoardConfig::new(
        sii_image(&DEVICE).expect("SII image"),
    ))));
    let shared = Rc::new(RefCell::new(Shared::default()));
    board.borrow_mut().set_cpu(Box::new(MinimalSlaveCpu {
        shared: shared.clone(),
    }));
    let storage = Box::new(Storage::new());
    let (tx, rx, pdu_loop) = storage.try_split().expect("split once");
    let md = MainDevice::new(
        pdu_loop,
        in_process_timeouts(),
        MainDeviceConfig {
            dc_static_sync_iterations: 20,
            ..Default::default()
        },
    );
    const PERIOD_NS: u64 = 50_000;
    block_on(or(
        async {
            let mut group = md
                .init_single_group::<2, 16>(ethercat_now)
                .await
                .expect("init");
            for mut sd in group.iter_mut(&md) {
                sd.set_dc_sync(ethercrab::DcSync::Sync0);
            }
            let group = group
                .configure_dc_sync(
                    &md,
                    ethercrab::subdevice_group::DcConfiguration {
                        start_delay: Duration::from_millis(1),
                        sync0_period: Duration::from_nanos(PERIOD_NS),
                        sync0_shift: Duration::ZERO,
                    },
                )
                .await
                .expect("configure DC");
            let group = group.into_safe_op(&md).await.expect("SAFE-OP");
            let group = group.request_into_op(&md).await.expect("request OP");
            for _ in 0..200 {
                group.tx_rx_dc(&md).await.expect("tx_rx_dc");
            }
        },
        tx_rx_task(board.clone(), tx, rx),
    ));
    let b = board.borrow();
    let edges = &b.sync_edges;
    assert!(edges.len() > 10, "only {} SYNC0 edges", edges.len());
    for w in edges.windows(2) {
        assert_eq!(w[1].system_time_ns - w[0].system_time_ns, PERIOD_NS);
    }
    assert_eq!(
        edges[0].system_time_ns % PERIOD_NS,
        0,
        "start rounded to the period"
    );
    assert_eq!(b.esc().borrow().peek_u8(regs::DC_ACTIVATION), 0x03);
    assert_eq!(shared.borrow().states.last(), Some(&8));
    let path = Path::new(env!("CARGO_TARGET_TMPDIR")).join(pcap);
    b.pcap().unwrap().save(&path).unwrap();
    eprintln!("{} SYNC0 edges; pcap -> {}", edges.len(), path.display());
    path
}
