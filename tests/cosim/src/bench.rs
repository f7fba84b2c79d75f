//! The image's figures for `cargo xtask bench` (issue 12, section 3), measured by running the
//! release image on the co-simulator under ethercrab ([`measure`], `lpc1754-cosim bench`):
//!
//! - a **profile run** ([`dc_run`] with mailbox traffic): per RTIC task (exception) its
//!   entry-to-exit cycles, own share of the CPU and stack; the sampler's share at 250 kSPS;
//!   SYNC0 edge -> LDAC edge; where the PDI task's cycles go;
//! - a **sweep** of DC cycle times ([`sweep`]) for the shortest one the image sustains
//!   with 2 AO + 8 AI (criteria: [`virtual_board::tools::image_figures::DcCheck`]).
//!
//! The format of the figures is the virtual board's ([`virtual_board::tools::image_figures`]),
//! so xtask reads them without linking this crate.

use crate::chip::Cpi;
use crate::cosim::{Facts, Options};
use crate::image::Image;
use crate::profile::THREAD;
use crate::run::{image_target, CosimHandle};
use crate::traffic::{moving_inputs, sdo_traffic, Jitter, SdoCounts, Traffic};
use coe_core::canopen::{cob, CanFrame, NmtCommand};
use ethercrab::subdevice_group::DcConfiguration;
use ethercrab::{DcSync, MainDevice, MainDeviceConfig, PduStorage};
use firmware::products::analog_io::device::DEVICE;
use firmware::products::analog_io::od::MODULE_DESCRIPTION_INDEX;
use firmware::products::analog_io::sync::MIN_CYCLE_TIME_NS;
use firmware::products::analog_io_can::can::DEFAULT_NODE_ID as CAN_NODE;
use std::cell::Cell;
use std::cell::RefCell;
use std::rc::Rc;
use std::time::Duration;
use virtual_board::models::adc::Signal;
use virtual_board::models::esc::regs;
use virtual_board::models::esc::SyncSignal;
use virtual_board::rig::board::VirtualBoard;
use virtual_board::rig::can_master::CanMaster;
use virtual_board::rig::master::{in_process_timeouts, tx_rx_task};
use virtual_board::rig::sdo_client::SdoClient;
use virtual_board::tools::image_figures::{
    shares_text, CpiSweep, DcCheck, HotCode, ImageFigures, Latency, Longest, ProfileRun,
    SamplerShare, Sweep, Vector,
};

/// A board shared between the master's rig and the measurement.
pub type Board = Rc<RefCell<VirtualBoard>>;

/// The ADC inputs of every DC run (volts, per channel): constants the AI values are checked
/// against.
pub const INPUTS_V: [f64; 8] = [1.0, 2.0, 3.0, 4.0, 5.0, 7.5, 8.0, 9.0];

/// Cycles run in OP before the judged ones (the first SYNC0 edges meet no outputs yet).
const WARM_UP_CYCLES: u64 = 20;
/// Cycles run after the judged ones (the last judged edge needs the next edge).
pub const TAIL_CYCLES: u64 = 2;

/// The cycle of the profile run: the virtual board's default (`cargo xtask sim`).
pub const PROFILE_CYCLE_NS: u64 = virtual_board::tools::sim::DEFAULT_CYCLE_US as u64 * 1000;

/// Cycle times the sweep starts from, longest first; it stops at the first that is not
/// sustained and then halves the gap to the last sustained one.
const SWEEP_START_US: [u64; 9] = [100, 80, 60, 50, 45, 40, 35, 30, 25];
/// Cycle times tried upwards, shortest first, when the first of [`SWEEP_START_US`] is not
/// sustained (a firmware slower than the advertised minimum), until one is.
const SWEEP_UP_US: [u64; 6] = [125, 150, 200, 300, 500, 1000];

/// The shortest stretch a cycle time is judged over: longer than the firmware's slowest
/// periodic work (the PDI task's safety service, every 100 ms), which a short run would
/// never meet.
const SWEEP_MIN_WINDOW_NS: u64 = 150_000_000;

/// How much to run: the short form for CI, the full one for the book's Performance chapter.
#[derive(Clone, Copy, Debug)]
pub struct Plan {
    /// Judged cycles of the profile run.
    pub profile_cycles: u64,
    /// Judged cycles per cycle time of the sweep, at least (see [`Plan::sweep_cycles`]).
    pub sweep_cycles: u64,
    /// The sweep stops halving the gap below this (ns).
    pub resolution_ns: u64,
}

impl Plan {
    /// The plan of `cargo xtask bench` (`quick`: `--quick`).
    pub fn new(quick: bool) -> Self {
        if quick {
            Self {
                profile_cycles: 1_000,
                sweep_cycles: 1_000,
                resolution_ns: 5_000,
            }
        } else {
            Self {
                profile_cycles: 10_000,
                sweep_cycles: 10_000,
                resolution_ns: 1_000,
            }
        }
    }

    /// Judged cycles at `cycle_ns`: the plan's count, or more to span
    /// [`SWEEP_MIN_WINDOW_NS`].
    pub fn sweep_cycles(&self, cycle_ns: u64) -> u64 {
        self.sweep_cycles
            .max(SWEEP_MIN_WINDOW_NS.div_ceil(cycle_ns.max(1)))
    }
}

/// Phases of a run, for where a long activation fell.
#[derive(Clone, Debug, Default)]
pub struct Phases {
    /// (start ns, name), in order.
    pub starts: Vec<(u64, &'static str)>,
}

impl Phases {
    fn enter(&mut self, t: u64, name: &'static str) {
        self.starts.push((t, name));
    }

    /// The phase `t` falls in.
    pub fn at(&self, t: u64) -> &'static str {
        self.starts
            .iter()
            .rev()
            .find(|(s, _)| *s <= t)
            .map_or("boot", |(_, n)| n)
    }
}

/// A DC run and the co-simulator's facts around its judged cycles.
pub struct DcRun {
    /// The criteria and figures of the judged cycles.
    pub check: DcCheck,
    /// Facts when the judged cycles started.
    pub before: Option<Facts>,
    /// Facts at the end of the run.
    pub after: Facts,
    /// Phases of the run.
    pub phases: Phases,
    /// The CAN traffic of the run ([`dc_run_with_can`]; zero without).
    pub can: CanSeen,
    /// The AL control and AL status writes of the run (the ESC's log).
    pub al_log: Vec<virtual_board::models::esc::AlWrite>,
    /// Every load of a DAC register in the run, in order (the AD5663 model's).
    pub dac_updates: Vec<virtual_board::models::dac::DacUpdate>,
    /// Every LDAC edge of the run, in order.
    pub ldac_edges: Vec<virtual_board::models::dac::LdacEdge>,
}

/// CANopen traffic on CAN1 during a DC run: the image's node is started (TPDO2 on every
/// SYNC) before the EtherCAT master runs, then a master on the board's bus sends a SYNC every
/// `sync_every` cycles and an SDO upload (0x1018:01) every `sdo_every` cycles, between them.
#[derive(Debug, Clone, Copy)]
pub struct CanLoad {
    /// Cycles from one SYNC to the next.
    pub sync_every: u64,
    /// Cycles from one SDO request to the next.
    pub sdo_every: u64,
}

/// What the CAN master sent and received during the OP cycles.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CanSeen {
    /// SYNCs sent.
    pub syncs: u64,
    /// TPDO2 frames received.
    pub tpdos: u64,
    /// SDO requests sent.
    pub sdo_requests: u64,
    /// SDO responses received.
    pub sdo_responses: u64,
}

/// The image's CANopen node started on the board's bus (boot-up seen, TPDO2 synchronous,
/// NMT start), before any EtherCAT traffic.
fn start_can_node(board: &Board) -> Result<CanMaster, String> {
    let node = u16::from(CAN_NODE);
    let can = CanMaster::attach(&board.borrow());
    let b = &mut *board.borrow_mut();
    can.wait_for(b, cob::NMT_ERROR_CONTROL + node, 500_000_000)
        .ok_or("no CAN boot-up message")?;
    can.download(b, CAN_NODE, 0x1801, 2, &[1])
        .map_err(|e| format!("TPDO2 transmission type: {e:?}"))?;
    can.nmt(NmtCommand::StartRemoteNode, CAN_NODE);
    b.step(5_000_000);
    can.take();
    Ok(can)
}

/// ethercrab's frame storage for one in-process master.
pub type Storage = PduStorage<16, { PduStorage::element_size(1100) }>;

/// ethercrab on `storage`, with the in-process rig's timeouts: the master and the two ends
/// of its frame loop for [`tx_rx_task`].
pub fn master(
    storage: &Storage,
) -> Result<(MainDevice<'_>, ethercrab::PduTx<'_>, ethercrab::PduRx<'_>), String> {
    let (tx, rx, pdu_loop) = storage
        .try_split()
        .map_err(|_| "PDU storage split twice".to_string())?;
    let md = MainDevice::new(
        pdu_loop,
        in_process_timeouts(),
        MainDeviceConfig {
            dc_static_sync_iterations: 50,
            ..Default::default()
        },
    );
    Ok((md, tx, rx))
}

/// A pair the master sent: frame time, AO1, AO2.
type Sent = (u64, i16, i16);

/// Runs the board up to virtual time `t` (nothing when it is there already).
pub fn step_to(board: &Board, t: u64) {
    let mut b = board.borrow_mut();
    let now = b.now_ns();
    if t > now {
        b.step(t - now);
    }
}

/// Runs the board until the DC unit's first SYNC0 pulse (its start time, 0x0990) is past.
pub fn sync0_started(board: &Board) {
    let (start, sys) = {
        let b = board.borrow();
        let esc = b.esc().borrow();
        let mut t = [0u8; 8];
        esc.peek(regs::DC_START_TIME, &mut t);
        (u64::from_le_bytes(t), esc.dc_system_time())
    };
    if start > sys {
        let now = board.borrow().now_ns();
        step_to(board, now + (start - sys) + 1_000);
    }
}

/// AL status and AL status code as the ESC holds them.
pub fn al_status(board: &Board) -> (u16, u16) {
    let b = board.borrow();
    let esc = b.esc().borrow();
    (
        esc.peek_u16(regs::AL_STATUS),
        esc.peek_u16(regs::AL_STATUS_CODE),
    )
}

/// Why a state change ethercrab asked for at `step` failed: its error and the ESC's AL
/// status and code.
pub fn refused(board: &Board, step: &str, e: ethercrab::error::Error) -> String {
    let (status, code) = al_status(board);
    format!("{step} refused: {e} (AL status {status:#06x}, AL status code {code:#06x})")
}

/// Writes `pdos` into the PDO assignment object `index` (0x1C12, 0x1C13) over SDO, as a
/// master does it: sub 0 = 0, the entries, sub 0 = their count.
pub async fn assign_pdos<S>(
    sd: &ethercrab::SubDeviceRef<'_, S>,
    index: u16,
    pdos: &[u16],
) -> Result<(), String>
where
    S: std::ops::Deref<Target = ethercrab::SubDevice>,
{
    sd.sdo_write(index, 0, 0u8)
        .await
        .map_err(|e| format!("{index:#06x}:00 = 0: {e}"))?;
    for (sub, pdo) in (1u8..).zip(pdos) {
        sd.sdo_write(index, sub, *pdo)
            .await
            .map_err(|e| format!("{index:#06x}:{sub} = {pdo:#06x}: {e}"))?;
    }
    sd.sdo_write(index, 0, pdos.len() as u8)
        .await
        .map_err(|e| format!("{index:#06x}:00 = {}: {e}", pdos.len()))
}

/// The output pair of cycle `i`: both channels change every cycle, within 0..=0x7FFF (0..10 V).
fn pair(i: u64) -> (i16, i16) {
    (
        ((i * 3 + 1) % 0x7FFF) as i16,
        (0x7FFF - (i * 7) % 0x7FFF) as i16,
    )
}

/// The DAC code an AO value loads (INTEGER16 0..=0x7FFF spans the 16-bit DAC's 0..10 V).
fn dac_code(v: i16) -> u16 {
    (v as u16) << 1
}

/// Stops the DC unit's SYNC0 and starts it again at `cycle_ns`, 1 ms from now, at a whole
/// number of cycles of system time (ETG.1020: 0x0981 off, cycle, start time, 0x0981 on).
async fn restart_sync0<S>(
    sd: &ethercrab::SubDeviceRef<'_, S>,
    cycle_ns: u64,
) -> Result<(), ethercrab::error::Error>
where
    S: std::ops::Deref<Target = ethercrab::SubDevice>,
{
    sd.register_write(regs::DC_ACTIVATION, 0u8).await?;
    sd.register_write(regs::DC_SYNC0_CYCLE, cycle_ns as u32)
        .await?;
    let now: u64 = sd.register_read(regs::DC_SYSTEM_TIME).await?;
    let start = (now + 1_000_000).div_ceil(cycle_ns) * cycle_ns;
    sd.register_write(regs::DC_START_TIME, start).await?;
    // Cyclic unit on, SYNC0 on.
    sd.register_write(regs::DC_ACTIVATION, 0x03u8).await?;
    Ok(())
}

/// Mailbox traffic in PRE-OP: SDO uploads and a download, SDO Information, a segmented upload.
async fn mailbox_traffic<S>(sd: &ethercrab::SubDeviceRef<'_, S>) -> Result<(), String>
where
    S: std::ops::Deref<Target = ethercrab::SubDevice>,
{
    let (mbx_out, mbx_in) = (DEVICE.sync_managers[0], DEVICE.sync_managers[1]);
    let mut client = SdoClient::<128>::new(mbx_out.start, mbx_in.start, 1);
    let up = client
        .upload(sd, MODULE_DESCRIPTION_INDEX, 0)
        .await
        .map_err(|e| e.to_string())?;
    if up.segments == 0 {
        return Err("the module description came without segments".into());
    }
    let e = |e: ethercrab::error::Error| e.to_string();
    sd.sdo_read::<u32>(0x1000, 0).await.map_err(e)?;
    sd.sdo_read::<heapless::String<64>>(0x1008, 0)
        .await
        .map_err(e)?;
    for sub in 1..=4 {
        sd.sdo_read::<u32>(0x1018, sub).await.map_err(e)?;
    }
    sd.sdo_write(0x6444, 1, 0i32).await.map_err(e)?;
    sd.sdo_info_object_description_list(ethercrab::ObjectDescriptionListQuery::All)
        .await
        .map_err(e)?;
    Ok(())
}

/// A program the DC runs drive on the co-simulated board: the release image, or a peer
/// stack ([`crate::peer`]) with the same process data (2 AO, 8 AI).
#[derive(Clone, Copy)]
pub struct Program<'a> {
    /// The flash.
    pub image: &'a Image,
    /// How it becomes the board's CPU (with its SII image).
    pub target:
        fn(Image, Options) -> Result<(virtual_board::tools::sim::Target, CosimHandle), String>,
    /// The shortest SYNC0 cycle it accepts at PRE-OP -> SAFE-OP (0x1C32:05).
    pub min_cycle_ns: u64,
    /// Virtual time the master waits before its first frame (the slave's boot, so the
    /// ESM rows time the transitions alone).
    pub boot_ns: u64,
    /// The time model's cycles per instruction instead of the chip's (a sensitivity run).
    pub cpi: Option<Cpi>,
}

impl<'a> Program<'a> {
    /// The release image.
    pub fn release(image: &'a Image) -> Self {
        Self {
            image,
            target: image_target,
            min_cycle_ns: u64::from(MIN_CYCLE_TIME_NS),
            boot_ns: 0,
            cpi: None,
        }
    }
}

/// Runs the image from reset to OP with DC SYNC0 at `cycle_ns` and judges `cycles` cycles
/// ([`DcCheck`]); with `mailbox`, mailbox traffic in PRE-OP first.
pub fn dc_run(image: &Image, cycle_ns: u64, cycles: u64, mailbox: bool) -> Result<DcRun, String> {
    dc_run_with_can(image, cycle_ns, cycles, mailbox, None)
}

/// [`dc_run`] with CANopen traffic on CAN1 ([`CanLoad`]) in the OP cycles.
pub fn dc_run_with_can(
    image: &Image,
    cycle_ns: u64,
    cycles: u64,
    mailbox: bool,
    can_load: Option<CanLoad>,
) -> Result<DcRun, String> {
    dc_run_program(
        &Program::release(image),
        cycle_ns,
        cycles,
        mailbox,
        can_load,
    )
}

/// [`dc_run_with_can`] for any [`Program`] (mailbox traffic and CAN load are the release
/// image's), with the ideal master.
pub fn dc_run_program(
    program: &Program,
    cycle_ns: u64,
    cycles: u64,
    mailbox: bool,
    can_load: Option<CanLoad>,
) -> Result<DcRun, String> {
    dc_run_traffic(
        program,
        cycle_ns,
        cycles,
        mailbox,
        can_load,
        &Traffic::IDEAL,
    )
}

/// [`dc_run_program`] under `traffic` (a real master's: [`Traffic::REAL_MASTER`]): SDO
/// traffic in OP, frame jitter, moving inputs, each judged ([`DcCheck`]).
pub fn dc_run_traffic(
    program: &Program,
    cycle_ns: u64,
    cycles: u64,
    mailbox: bool,
    can_load: Option<CanLoad>,
    traffic: &Traffic,
) -> Result<DcRun, String> {
    let options = Options {
        cpi: program.cpi,
        ..Options::default()
    };
    let (target, handle) = (program.target)(program.image.clone(), options)?;
    let board = Rc::new(RefCell::new(target.into_board(|cfg| cfg.capture = false)));
    {
        let adc = board.borrow().adc().clone();
        let mut adc = adc.borrow_mut();
        let moving = moving_inputs();
        for (i, v) in INPUTS_V.iter().enumerate() {
            adc.inputs[i] = match traffic.moving_inputs {
                true => moving[i].clone(),
                false => Signal::Constant(*v),
            };
        }
    }
    let facts = || {
        handle
            .with(|c| c.facts())
            .ok_or_else(|| "the co-simulator did not start".to_string())
    };
    let can = match can_load {
        Some(load) => Some((load, start_can_node(&board)?)),
        None => None,
    };
    let mut can_seen = CanSeen::default();
    let storage: Box<Storage> = Box::new(PduStorage::new());
    let (md, tx, rx) = master(&storage)?;
    let mut phases = Phases::default();
    let mut check = DcCheck {
        cycle_ns,
        planned: cycles,
        ..Default::default()
    };
    let mut sent: Vec<Sent> = Vec::new();
    let mut before: Option<Facts> = None;
    let mut start = 0u64;
    let mut adc_violations = 0;
    let mut jitter = Jitter::new(traffic.jitter_ns);
    let stop_sdo = Cell::new(false);
    let sdo_counts = Cell::new(SdoCounts::default());
    let mut last_inputs: Option<Vec<u8>> = None;
    step_to(&board, program.boot_ns);
    let master = async {
        phases.enter(0, "boot and INIT -> PRE-OP");
        // DC time from the board's clock, not the wall clock: the cycle's phase against the
        // firmware's periodic work is then the same in every run.
        let clock = board.borrow().clock().clone();
        let mut group = md
            .init_single_group::<2, 64>(|| clock.now_ns())
            .await
            .map_err(|e| format!("INIT -> PRE-OP: {e}"))?;
        if mailbox {
            phases.enter(board.borrow().now_ns(), "mailbox traffic in PRE-OP");
            let sd = group.subdevice(&md, 0).map_err(|e| e.to_string())?;
            mailbox_traffic(&sd).await?;
        }
        phases.enter(board.borrow().now_ns(), "PRE-OP -> OP with DC");
        for mut sd in group.iter_mut(&md) {
            sd.set_dc_sync(DcSync::Sync0);
        }
        let group = group
            .into_pre_op_pdi(&md)
            .await
            .map_err(|e| format!("process data: {e}"))?;
        // The firmware refuses a SYNC0 cycle below its advertised minimum at PRE-OP ->
        // SAFE-OP (0x0035); it reads the cycle there only. Below it, the check sees the
        // minimum and the DC unit runs the cycle under test from SAFE-OP on.
        let checked_ns = cycle_ns.max(program.min_cycle_ns);
        let group = group
            .configure_dc_sync(
                &md,
                DcConfiguration {
                    // ethercrab rounds the first pulse down to a whole cycle: with a delay
                    // of one cycle only it can fall before the activation's write, and the
                    // unit never starts.
                    start_delay: Duration::from_nanos(1_000_000 + checked_ns),
                    sync0_period: Duration::from_nanos(checked_ns),
                    sync0_shift: Duration::from_nanos(checked_ns / 2),
                },
            )
            .await
            .map_err(|e| format!("DC: {e}"))?;
        let group = group
            .into_safe_op(&md)
            .await
            .map_err(|e| refused(&board, "PRE-OP -> SAFE-OP", e))?;
        if checked_ns != cycle_ns {
            let sd = group.subdevice(&md, 0).map_err(|e| e.to_string())?;
            restart_sync0(&sd, cycle_ns)
                .await
                .map_err(|e| format!("SYNC0 reprogrammed to {cycle_ns} ns: {e}"))?;
        }
        // SAFE-OP -> OP once SYNC0 runs (the DC start time passed), as masters do: a slave
        // may count SM2 events against SYNC0 edges from OP on (SOES does).
        sync0_started(&board);
        let group = group
            .into_op(&md)
            .await
            .map_err(|e| refused(&board, "SAFE-OP -> OP", e))?;
        phases.enter(board.borrow().now_ns(), "OP with process data");
        let sdo = async {
            if !traffic.mailbox_in_op {
                return Ok(());
            }
            let sd = group.subdevice(&md, 0).map_err(|e| e.to_string())?;
            sdo_traffic(&sd, &stop_sdo, &sdo_counts).await
        };
        let cycles_run = async {
            for i in 0..WARM_UP_CYCLES + cycles + TAIL_CYCLES {
                if i == WARM_UP_CYCLES {
                    before = Some(facts()?);
                    start = board.borrow().now_ns();
                    adc_violations = board.borrow().adc().borrow().cycle_violations;
                }
                let (a, b) = pair(i);
                {
                    let sd = group.subdevice(&md, 0).map_err(|e| e.to_string())?;
                    let mut o = sd.outputs_raw_mut();
                    o[0..2].copy_from_slice(&a.to_le_bytes());
                    o[2..4].copy_from_slice(&b.to_le_bytes());
                }
                let t0 = board.borrow().now_ns();
                let resp = match group.tx_rx_dc(&md).await {
                    Ok(r) => r,
                    Err(e) => return Err(format!("cycle {i}: {e}")),
                };
                if !resp.all_op() {
                    let (status, code) = al_status(&board);
                    return Err(format!(
                        "the slave left OP at cycle {i} (AL status {status:#06x}, AL status code \
                     {code:#06x})"
                    ));
                }
                sent.push((t0, a, b));
                if let Some((load, can)) = &can {
                    if i % load.sync_every == 0 {
                        can.sync();
                        can_seen.syncs += 1;
                    }
                    if i % load.sdo_every == load.sdo_every / 2 {
                        // Expedited upload request of 0x1018:01 (CiA 301 ccs 2).
                        let request = [0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0];
                        let id = cob::SDO_RX + u16::from(CAN_NODE);
                        if let Ok(frame) = CanFrame::new(id, &request) {
                            can.send(frame);
                            can_seen.sdo_requests += 1;
                        }
                    }
                }
                if i >= WARM_UP_CYCLES {
                    let sd = group.subdevice(&md, 0).map_err(|e| e.to_string())?;
                    let img = sd.inputs_raw();
                    if traffic.moving_inputs {
                        // The SM3 image of this cycle must not be the last cycle's.
                        let ai = img.get(..16).unwrap_or(&[]).to_vec();
                        check.late_inputs += u64::from(last_inputs.as_ref() == Some(&ai));
                        last_inputs = Some(ai);
                    } else {
                        let off = INPUTS_V.iter().enumerate().any(|(ch, v)| {
                            let ai = i16::from_le_bytes([img[2 * ch], img[2 * ch + 1]]);
                            (f64::from(ai) - v / 10.0 * 32768.0).abs() > 1.0
                        });
                        check.stale_inputs += u64::from(off);
                    }
                }
                // ethercrab paces by the cycle it configured; the SYNC0 edges run at `cycle_ns`
                // from a start that is a whole number of cycles, half a cycle after the frame,
                // give or take the master's jitter.
                let phase = resp.extra.dc_system_time % cycle_ns;
                let nominal = t0 + (cycle_ns - phase) + cycle_ns / 2;
                step_to(&board, nominal.saturating_add_signed(jitter.next_ns()));
            }
            Ok::<(), String>(())
        };
        // The SDO traffic ends with the cycles, however they end.
        let cyclic = async {
            let r = cycles_run.await;
            stop_sdo.set(true);
            r
        };
        let (cyclic, sdo) = futures_lite::future::zip(cyclic, sdo).await;
        cyclic?;
        sdo.map_err(|e| format!("SDO traffic in OP: {e}"))
    };
    let result = futures_lite::future::block_on(futures_lite::future::or(
        master,
        tx_rx_task(board.clone(), tx, rx),
    ));
    if let Some((_, can)) = &can {
        let tpdo2 = cob::tpdo(2, CAN_NODE);
        for (_, frame) in can.take() {
            if Some(frame.id()) == tpdo2 {
                can_seen.tpdos += 1;
            } else if frame.id() == cob::SDO_TX + u16::from(CAN_NODE) {
                can_seen.sdo_responses += 1;
            }
        }
    }
    let after = facts()?;
    if let Some(f) = &after.fault {
        check.failure = Some(format!("the image faulted: {f}"));
    } else if !after.reports.is_empty() {
        check.failure = Some(format!(
            "a model reported a problem: {}",
            after.reports[0].message
        ));
    } else if let Err(e) = result {
        check.failure = Some(e);
    }
    if let Some(b) = &before {
        judge(&board, &sent, start, adc_violations, b, &after, &mut check);
    }
    check.sdo_exchanges = sdo_counts.get().exchanges;
    check.traffic = traffic.describe();
    check.judge_ldac = *traffic != Traffic::IDEAL;
    let al_log = board.borrow().esc().borrow().al_log.clone();
    let (dac_updates, ldac_edges) = {
        let b = board.borrow();
        let dac = b.dac().borrow();
        (dac.updates.clone(), dac.ldac_edges.clone())
    };
    Ok(DcRun {
        check,
        before,
        after,
        phases,
        can: can_seen,
        al_log,
        dac_updates,
        ldac_edges,
    })
}

/// The criteria over the judged cycles, from `start` on (the ADC model had counted
/// `adc_violations` then).
fn judge(
    board: &Board,
    sent: &[Sent],
    start: u64,
    adc_violations: u64,
    before: &Facts,
    after: &Facts,
    check: &mut DcCheck,
) {
    let b = board.borrow();
    let edges: Vec<u64> = b
        .sync_edges
        .iter()
        .filter(|e| e.signal == SyncSignal::Sync0 && e.time_ns >= start)
        .map(|e| e.time_ns)
        .collect();
    // Both channels loaded at the same instant: an LDAC edge (or a write-and-update-all).
    let updates = b.dac().borrow().updates.clone();
    let latches: Vec<(u64, u16, u16)> = updates
        .windows(2)
        .filter(|w| w[0].time_ns >= start && w[0].time_ns == w[1].time_ns)
        .filter_map(|w| match (w[0].channel, w[1].channel) {
            (0, 1) => Some((w[0].time_ns, w[0].code, w[1].code)),
            (1, 0) => Some((w[0].time_ns, w[1].code, w[0].code)),
            _ => None,
        })
        .collect();
    let mut latencies = Vec::new();
    let last_frame = sent.last().map_or(0, |s| s.0);
    for pairs in edges.windows(2) {
        let (edge, next) = (pairs[0], pairs[1]);
        if edge > last_frame || check.edges == check.planned {
            break;
        }
        check.edges += 1;
        let expected = sent
            .iter()
            .rev()
            .find(|s| s.0 < edge)
            .map(|s| (dac_code(s.1), dac_code(s.2)));
        match latches.iter().find(|l| l.0 >= edge && l.0 < next) {
            Some(&(t, a, bb)) if expected == Some((a, bb)) => latencies.push(t - edge),
            _ => check.stale_outputs += 1,
        }
    }
    check.sync0_to_ldac = latency(&latencies);
    check.missed_sync0 = after.sync0_unserved - before.sync0_unserved;
    check.lost_samples = (after.samples.lost - before.samples.lost)
        + (after.ssp1_overruns - before.ssp1_overruns)
        + (b.adc().borrow().cycle_violations - adc_violations);
    check.conversions = after.traffic.adc_conversions - before.traffic.adc_conversions;
    let cycles = after.cycles - before.cycles;
    let sleep = after.sleep_cycles - before.sleep_cycles;
    check.cpu_load = 1.0 - sleep as f64 / cycles.max(1) as f64;
}

fn latency(ns: &[u64]) -> Latency {
    if ns.is_empty() {
        return Latency::default();
    }
    Latency {
        count: ns.len() as u64,
        min_ns: *ns.iter().min().expect("not empty"),
        mean_ns: ns.iter().sum::<u64>() as f64 / ns.len() as f64,
        max_ns: *ns.iter().max().expect("not empty"),
        histogram: ns
            .iter()
            .fold(std::collections::BTreeMap::new(), |mut h, &n| {
                *h.entry(n).or_insert(0u64) += 1;
                h
            })
            .into_iter()
            .collect(),
    }
}

/// Exception number of the PDI task (EINT3, the ESC's IRQ line).
pub const PDI_TASK: u32 = crate::nvic::exc::IRQ0 + crate::nvic::irq::EINT3;
/// Exception number of the GPDMA interrupt (the sampler's half-ring count).
pub const DMA_IRQ: u32 = crate::nvic::exc::IRQ0 + crate::nvic::irq::DMA;

/// What the PDI task's cycles are spent on: (label, functions any of which in a code chain
/// puts it there), checked in order. Calls out of line are chains of their own, so the ESC
/// accesses of every caller count as ESC accesses.
const PDI_WORK: [(&str, &[&str]); 6] = [
    (
        "ET1100 accesses (legacy SPI byte loop with its SPIF polling, chip select, et1100 driver)",
        &["LegacySpi", "CsDevice", "et1100::", "EscPdi"],
    ),
    ("ADC ring drain", &["AdcSource::drain_into"]),
    (
        "inputs to SM3 (sampler publish, packing)",
        &["write_inputs"],
    ),
    (
        "mailbox (CoE, SDO server, SDO Information)",
        &["mailbox", "Mailbox", "sdo_server", "coe_core::"],
    ),
    (
        "outputs from SM2 (unpacking, staging)",
        &["outputs", "Outputs"],
    ),
    ("time base", &["now_ns"]),
];

/// Cycles per [`PDI_WORK`] label (and "other") of `code` (chain, instructions), as shares.
fn pdi_breakdown(facts: &Facts, code: impl Iterator<Item = (u32, u64)>) -> Vec<(String, f64)> {
    let mut sums = vec![0u64; PDI_WORK.len() + 1];
    for (chain, n) in code {
        let names = facts.chain(chain);
        let i = PDI_WORK
            .iter()
            .position(|(_, keys)| names.iter().any(|f| keys.iter().any(|k| f.contains(k))))
            .unwrap_or(PDI_WORK.len());
        sums[i] += n;
    }
    let total = sums.iter().sum::<u64>().max(1) as f64;
    PDI_WORK
        .iter()
        .map(|(label, _)| *label)
        .chain(["other (ESM, sync monitor, events, task glue)"])
        .zip(sums)
        .map(|(label, n)| (label.to_string(), n as f64 / total))
        .collect()
}

/// Crates of the project: [`hot_code`] names a chain after its innermost function of one.
const OWN_CRATES: [&str; 6] = [
    "firmware::",
    "analog_io::",
    "et1100::",
    "ad5663::",
    "ad7689::",
    "coe_core::",
];

/// Functions shown per task in [`ProfileRun::hot_code`].
const HOT_FUNCTIONS: usize = 16;

/// Per task (every exception that ran code between `before` and `after`), its
/// [`HOT_FUNCTIONS`] most expensive functions in cycles per judged DC cycle (`cycles` of them).
fn hot_code(before: &Facts, after: &Facts, vectors: &[Vector], cycles: u64) -> Vec<HotCode> {
    let own = |f: &&String| {
        let f = f.trim_start_matches('<');
        OWN_CRATES.iter().any(|c| f.starts_with(c))
    };
    let mut out = Vec::new();
    for v in vectors.iter().filter(|v| v.number != THREAD) {
        let mut by_name: Vec<(String, u64)> = Vec::new();
        for (chain, n) in code_between(before, after, v.number) {
            let names = after.chain(chain);
            let name = names.iter().rev().find(own).or(names.last());
            let name = name.cloned().unwrap_or_default();
            match by_name.iter_mut().find(|(f, _)| *f == name) {
                Some((_, i)) => *i += n,
                None => by_name.push((name, n)),
            }
        }
        by_name.sort_by(|a, b| b.1.cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
        out.extend(
            by_name
                .into_iter()
                .take(HOT_FUNCTIONS)
                .map(|(function, n)| HotCode {
                    task: v.task.clone().unwrap_or_else(|| v.name.clone()),
                    function,
                    cycles_per_cycle: crate::cosim::instruction_cycles(n) as f64
                        / cycles.max(1) as f64,
                }),
        );
    }
    out
}

/// (chain, instructions) that context `context` executed between `before` and `after`.
fn code_between(before: &Facts, after: &Facts, context: u32) -> Vec<(u32, u64)> {
    after
        .code
        .iter()
        .filter(|c| c.context == context)
        .map(|c| {
            let earlier = before
                .code
                .iter()
                .find(|b| b.context == context && b.chain == c.chain)
                .map_or(0, |b| b.instructions);
            (c.chain, c.instructions - earlier)
        })
        .filter(|(_, n)| *n > 0)
        .collect()
}

fn own_cycles(facts: &Facts, n: u32) -> u64 {
    facts.exception(n).map_or(0, |e| e.own_cycles)
}

/// The RTIC task exception `n` (named `vector`) runs, from the image's debug information:
/// RTIC's handler `VECTOR` calls `rtic_app::VECTOR::exec`, which inlines the task's function;
/// thread mode runs `init` and `idle`.
fn task_name(facts: &Facts, n: u32, vector: &str) -> Option<String> {
    if n == THREAD {
        return Some("init, idle".into());
    }
    let exec = format!("::{vector}::exec");
    facts.code.iter().filter(|c| c.context == n).find_map(|c| {
        let chain = facts.chain(c.chain);
        let at = chain.iter().position(|f| f.ends_with(&exec))?;
        let task = chain.get(at + 1)?;
        Some(task.rsplit("::").next()?.to_string())
    })
}

/// The profile run: from reset with mailbox traffic, then `cycles` DC cycles at
/// [`PROFILE_CYCLE_NS`]; and the CPU clock the image ran at (Hz).
pub fn profile_run(image: &Image, cycles: u64) -> Result<(ProfileRun, u64), String> {
    let run = dc_run(image, PROFILE_CYCLE_NS, cycles, true)?;
    if let Some(f) = &run.check.failure {
        return Err(format!("the profile run failed: {f}"));
    }
    let before = run
        .before
        .as_ref()
        .ok_or("the profile run reached no process data")?;
    let after = &run.after;
    let vectors: Vec<Vector> = after
        .exceptions
        .iter()
        .map(|(n, name, e)| Vector {
            number: *n,
            name: if *n == THREAD {
                "thread mode".into()
            } else {
                name.clone()
            },
            task: task_name(after, *n, name),
            priority: after.priorities.iter().find(|p| p.0 == *n).map(|p| p.1),
            activations: e.count,
            mean_cycles: e.cycles as f64 / e.count.max(1) as f64,
            max_cycles: e.max_cycles,
            own_share: e.own_cycles as f64 / after.cycles.max(1) as f64,
            max_stack: u64::from(e.max_stack),
        })
        .collect();
    // Tasks of one priority level never nest; the levels can, on top of idle.
    let mut levels: Vec<(u8, u64)> = Vec::new();
    for v in &vectors {
        if let Some(p) = v.priority {
            match levels.iter_mut().find(|l| l.0 == p) {
                Some(l) => l.1 = l.1.max(v.max_stack),
                None => levels.push((p, v.max_stack)),
            }
        }
    }
    let init_stack = vectors.first().map_or(0, |v| v.max_stack);
    let stack_bound = init_stack
        .max(u64::from(after.thread_stack_with_tasks) + levels.iter().map(|l| l.1).sum::<u64>());
    let cycles_window = (after.cycles - before.cycles).max(1) as f64;
    let seconds = (after.time_ns - before.time_ns).max(1) as f64 * 1e-9;
    let drain = |f: &Facts| f.cycles_in(None, |n| n.contains("AdcSource::drain_into"));
    let dma_irq = own_cycles(after, DMA_IRQ) - own_cycles(before, DMA_IRQ);
    let drain_cycles = drain(after) - drain(before);
    let sampler = SamplerShare {
        conversions_per_s: (after.traffic.adc_conversions - before.traffic.adc_conversions) as f64
            / seconds,
        dma_irq_cycles_per_s: dma_irq as f64 / seconds,
        drain_cycles_per_s: drain_cycles as f64 / seconds,
        share: (dma_irq + drain_cycles) as f64 / cycles_window,
    };
    let pdi = after.exception(PDI_TASK).ok_or("the PDI task never ran")?;
    let hot_code = hot_code(before, after, &vectors, run.check.edges);
    let profile = ProfileRun {
        dc: run.check.clone(),
        vectors,
        deepest_stack: u64::from(after.stack_used),
        stack_bound,
        sampler,
        pdi_task: pdi_breakdown(after, code_between(before, after, PDI_TASK).into_iter()),
        pdi_longest: Longest {
            cycles: pdi.max_cycles,
            phase: run.phases.at(pdi.max_at_ns).to_string(),
            work: pdi_breakdown(after, pdi.longest_code.iter().copied()),
        },
        hot_code,
    };
    Ok((profile, after.cclk_hz))
}

/// The cycle times to try, in order, until the shortest sustained one is known to
/// `resolution_ns`: from [`SWEEP_START_US`] down until a cycle is not sustained (or, when the
/// first is not, up through [`SWEEP_UP_US`] until one is), then the gap between the two
/// halved. `sustained` runs a cycle time (ns) and judges it.
fn search(resolution_ns: u64, mut sustained: impl FnMut(u64) -> bool) {
    let mut good = None;
    let mut bad = None;
    for us in SWEEP_START_US {
        if sustained(us * 1000) {
            good = Some(us * 1000);
        } else {
            bad = Some(us * 1000);
            break;
        }
    }
    if good.is_none() {
        for us in SWEEP_UP_US {
            if sustained(us * 1000) {
                good = Some(us * 1000);
                break;
            }
            bad = Some(us * 1000);
        }
    }
    if let (Some(mut g), Some(mut b)) = (good, bad) {
        while g - b > resolution_ns {
            let mid = (g + b) / 2 / resolution_ns * resolution_ns;
            let mid = mid.clamp(b + resolution_ns, g - resolution_ns);
            if sustained(mid) {
                g = mid;
            } else {
                b = mid;
            }
        }
    }
}

/// The shortest DC cycle the image sustains, searched as [`search`] does; then `also_ns`, if
/// given and not tried yet (a cycle time a caller's rule turns on).
pub fn sweep(
    image: &Image,
    plan: &Plan,
    also_ns: Option<u64>,
    progress: &mut dyn FnMut(&DcCheck),
) -> Sweep {
    let traffic = Traffic::REAL_MASTER;
    sweep_program(&Program::release(image), plan, also_ns, &traffic, progress)
}

/// [`sweep`] for any [`Program`].
pub fn sweep_program(
    program: &Program,
    plan: &Plan,
    also_ns: Option<u64>,
    traffic: &Traffic,
    progress: &mut dyn FnMut(&DcCheck),
) -> Sweep {
    let mut points = search_program(program, plan, traffic, progress);
    let mut run = |cycle_ns: u64, points: &mut Vec<DcCheck>| {
        let check = judge_cycle(program, plan, cycle_ns, traffic);
        progress(&check);
        points.push(check);
    };
    // A shorter cycle sustained says nothing of a longer one (the firmware's periodic work
    // falls elsewhere in the cycle): every cycle up to 1 ms, at log-spaced steps.
    let shortest = points
        .iter()
        .filter(|p| p.sustained())
        .map(|p| p.cycle_ns)
        .min();
    for ns in shortest.map(log_steps).unwrap_or_default() {
        if !points.iter().any(|p| p.cycle_ns == ns) {
            run(ns, &mut points);
        }
    }
    if let Some(ns) = also_ns.filter(|ns| !points.iter().any(|p| p.cycle_ns == *ns)) {
        run(ns, &mut points);
    }
    Sweep {
        points,
        method: format!(
            "{} judged cycles per cycle time, at least {} ms, under {}; from {} us down ({} us \
             first; up through {} us when {} us is not sustained; then halving the gap to {} \
             us), then {} log-spaced steps from the shortest sustained to 1 ms",
            plan.sweep_cycles,
            SWEEP_MIN_WINDOW_NS / 1_000_000,
            traffic.describe(),
            SWEEP_START_US[0],
            list(&SWEEP_START_US),
            list(&SWEEP_UP_US),
            SWEEP_START_US[0],
            plan.resolution_ns / 1000,
            LOG_STEPS
        ),
    }
}

/// `cycle_ns` judged under `traffic` with the plan's cycles (a run that could not be made
/// is a failure of that cycle time).
fn judge_cycle(program: &Program, plan: &Plan, cycle_ns: u64, traffic: &Traffic) -> DcCheck {
    let cycles = plan.sweep_cycles(cycle_ns);
    match dc_run_traffic(program, cycle_ns, cycles, false, None, traffic) {
        Ok(r) => r.check,
        Err(e) => DcCheck {
            cycle_ns,
            planned: cycles,
            failure: Some(e),
            ..Default::default()
        },
    }
}

/// The cycle times [`search`] tries for `program`, each judged under `traffic`.
fn search_program(
    program: &Program,
    plan: &Plan,
    traffic: &Traffic,
    progress: &mut dyn FnMut(&DcCheck),
) -> Vec<DcCheck> {
    let mut points = Vec::new();
    search(plan.resolution_ns, |ns| {
        let check = judge_cycle(program, plan, ns, traffic);
        progress(&check);
        let ok = check.sustained();
        points.push(check);
        ok
    });
    points
}

/// The time model's sensitivity: cycles per instruction 20 % below and above the chip's
/// (5/4 on the LPC1754: 1/1 and 3/2). The co-simulator counts every instruction at the
/// same CPI, with no flash-accelerator misses or APB wait states; the shortest sustained
/// cycle at the dearer CPI is what the advertised minimum must cover.
pub const CPI_SENSITIVITY: [Cpi; 2] = [Cpi { num: 1, den: 1 }, Cpi { num: 3, den: 2 }];

/// The shortest sustained DC cycle searched again at each of [`CPI_SENSITIVITY`] (as
/// [`sweep`] searches it, without the steps up to 1 ms), then the advertised minimum
/// judged at each if the search did not try it.
pub fn cpi_sensitivity(
    image: &Image,
    plan: &Plan,
    progress: &mut dyn FnMut(Cpi, &DcCheck),
) -> Vec<CpiSweep> {
    let traffic = Traffic::REAL_MASTER;
    CPI_SENSITIVITY
        .iter()
        .map(|&cpi| {
            let program = Program {
                cpi: Some(cpi),
                ..Program::release(image)
            };
            let mut points = search_program(&program, plan, &traffic, &mut |c| progress(cpi, c));
            let min = u64::from(MIN_CYCLE_TIME_NS);
            if !points.iter().any(|p| p.cycle_ns == min) {
                let check = judge_cycle(&program, plan, min, &traffic);
                progress(cpi, &check);
                points.push(check);
            }
            CpiSweep {
                cpi: (cpi.num, cpi.den),
                sweep: Sweep {
                    points,
                    method: format!(
                        "CPI {}/{}: the sweep's search under {}, then {} us",
                        cpi.num,
                        cpi.den,
                        traffic.describe(),
                        min / 1000
                    ),
                },
            }
        })
        .collect()
}

/// Steps of the sweep above the shortest sustained cycle, up to 1 ms.
const LOG_STEPS: u32 = 6;
/// The longest cycle the sweep checks (ns).
const SWEEP_LONGEST_NS: u64 = 1_000_000;

/// `LOG_STEPS` cycle times from above `shortest_ns` to 1 ms, evenly spaced on a log scale,
/// rounded to 1 us.
fn log_steps(shortest_ns: u64) -> Vec<u64> {
    let (lo, hi) = (shortest_ns as f64, SWEEP_LONGEST_NS as f64);
    if lo >= hi {
        return Vec::new();
    }
    (1..=LOG_STEPS)
        .map(|k| {
            let ns = lo * (hi / lo).powf(f64::from(k) / f64::from(LOG_STEPS));
            (ns / 1000.0).round() as u64 * 1000
        })
        .collect()
}

/// "a, b, c".
fn list(us: &[u64]) -> String {
    us.iter()
        .map(|u| u.to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

/// Everything `cargo xtask bench` takes from the image; `also_ns`: a cycle time the sweep
/// tries too.
pub fn measure(
    image: &Image,
    elf: &str,
    quick: bool,
    also_ns: Option<u64>,
    progress: &mut dyn FnMut(&str),
) -> Result<ImageFigures, String> {
    let plan = Plan::new(quick);
    progress(&format!(
        "profile run: mailbox traffic, then {} DC cycles of {} us",
        plan.profile_cycles,
        PROFILE_CYCLE_NS / 1000
    ));
    let (profile, cclk_hz) = profile_run(image, plan.profile_cycles)?;
    let sweep = sweep(image, &plan, also_ns, &mut |c| {
        progress(&format!(
            "cycle {:.1} us: {} (CPU load {:.1} %)",
            c.cycle_ns as f64 / 1e3,
            c.verdict(),
            100.0 * c.cpu_load
        ))
    });
    let cpi_sensitivity = cpi_sensitivity(image, &plan, &mut |cpi, c| {
        progress(&format!(
            "CPI {}/{}, cycle {:.1} us: {} (CPU load {:.1} %)",
            cpi.num,
            cpi.den,
            c.cycle_ns as f64 / 1e3,
            c.verdict(),
            100.0 * c.cpu_load
        ))
    });
    Ok(ImageFigures {
        quick,
        elf: elf.to_string(),
        flash_bytes: u64::from(image.flash_bytes),
        static_ram_bytes: u64::from(image.static_ram),
        stack_bytes: u64::from(image.initial_sp().saturating_sub(image.stack_floor)),
        cpi: (crate::machine::CPI_NUM, crate::machine::CPI_DEN),
        cclk_hz,
        profile,
        sweep,
        cpi_sensitivity,
    })
}

/// The figures as text, one line each.
pub fn summary(f: &ImageFigures) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let us = |cycles: f64| cycles / f.cclk_hz as f64 * 1e6;
    let _ = writeln!(
        s,
        "image {}: {} B flash, {} B static RAM, {} B stack; CPI {}/{} at {} MHz",
        f.elf,
        f.flash_bytes,
        f.static_ram_bytes,
        f.stack_bytes,
        f.cpi.0,
        f.cpi.1,
        f.cclk_hz / 1_000_000
    );
    let p = &f.profile;
    let _ = writeln!(
        s,
        "profile run, OP at {} us: {} ({} edges), CPU load {:.1} %",
        p.dc.cycle_ns / 1000,
        p.dc.verdict(),
        p.dc.edges,
        100.0 * p.dc.cpu_load
    );
    for v in &p.vectors {
        let _ = writeln!(
            s,
            "  {:<30} prio {:>4}: {:>7} activations, entry..exit {:>6.0} cycles mean ({:.2} us), \
             {:>6} max ({:.2} us); own {:>5.1} % of the CPU; stack {:>4} B",
            format!(
                "{} ({}, {})",
                v.task.as_deref().unwrap_or("-"),
                v.name,
                v.number
            ),
            v.priority.map_or("-".into(), |p| format!("{p:#04x}")),
            v.activations,
            v.mean_cycles,
            us(v.mean_cycles),
            v.max_cycles,
            us(v.max_cycles as f64),
            100.0 * v.own_share,
            v.max_stack
        );
    }
    let _ = writeln!(
        s,
        "  stack: deepest seen {} B; bound (init, or idle + the deepest task of each priority level) {} B",
        p.deepest_stack, p.stack_bound
    );
    let l = &p.dc.sync0_to_ldac;
    let _ = writeln!(
        s,
        "  SYNC0 -> LDAC: {:.0} ns mean ({:.0} cycles), {} ns min, {} ns max ({:.0} cycles) over {} edges",
        l.mean_ns,
        l.mean_ns * f.cclk_hz as f64 / 1e9,
        l.min_ns,
        l.max_ns,
        l.max_ns as f64 * f.cclk_hz as f64 / 1e9,
        l.count
    );
    let a = &p.sampler;
    let _ = writeln!(
        s,
        "  sampler: {:.1} kSPS, {:.2} % of the CPU (GPDMA interrupt {:.0} cycles/s, ring drain {:.0} cycles/s)",
        a.conversions_per_s / 1e3,
        100.0 * a.share,
        a.dma_irq_cycles_per_s,
        a.drain_cycles_per_s
    );
    let _ = writeln!(s, "  PDI task in OP: {}", shares_text(&p.pdi_task));
    let _ = writeln!(
        s,
        "  PDI task's longest activation: {} cycles, in {}: {}",
        p.pdi_longest.cycles,
        p.pdi_longest.phase,
        shares_text(&p.pdi_longest.work)
    );
    let _ = writeln!(s, "sweep ({}):", f.sweep.method);
    for c in &f.sweep.points {
        let _ = writeln!(
            s,
            "  {:>6.1} us: {} (CPU load {:.1} %, SYNC0 -> LDAC max {} ns)",
            c.cycle_ns as f64 / 1e3,
            c.verdict(),
            100.0 * c.cpu_load,
            c.sync0_to_ldac.max_ns
        );
    }
    match f.sweep.shortest_sustained() {
        Some(c) => {
            let _ = writeln!(
                s,
                "shortest DC cycle sustained: {:.1} us{}",
                c.cycle_ns as f64 / 1e3,
                f.sweep.first_failing().map_or(String::new(), |b| format!(
                    " ({:.1} us is not: {})",
                    b.cycle_ns as f64 / 1e3,
                    b.verdict()
                ))
            );
        }
        None => {
            let _ = writeln!(
                s,
                "shortest DC cycle sustained: none of the cycle times tried"
            );
        }
    }
    for c in &f.cpi_sensitivity {
        let _ = writeln!(s, "{}", cpi_line(c, f.cpi));
    }
    s
}

/// "at CPI 3/2 (x1.20): shortest sustained 262 us (261 us is not: ...); 270 us sustained".
pub fn cpi_line(c: &CpiSweep, nominal: (u64, u64)) -> String {
    let nominal = nominal.0 as f64 / nominal.1 as f64;
    let us = |ns: u64| ns as f64 / 1e3;
    let shortest = match c.sweep.shortest_sustained() {
        Some(p) => format!(
            "shortest sustained {:.0} us{}",
            us(p.cycle_ns),
            c.sweep.first_failing().map_or(String::new(), |b| format!(
                " ({:.0} us is not: {})",
                us(b.cycle_ns),
                b.verdict()
            ))
        ),
        None => "none of the cycle times tried sustained".to_string(),
    };
    let min = u64::from(MIN_CYCLE_TIME_NS);
    let at_min = c
        .sweep
        .points
        .iter()
        .find(|p| p.cycle_ns == min)
        .map_or(String::new(), |p| {
            format!(
                "; {:.0} us (the advertised minimum): {}",
                us(min),
                p.verdict()
            )
        });
    format!(
        "time model at CPI {}/{} (x{:.2}): {shortest}{at_min}",
        c.cpi.0,
        c.cpi.1,
        c.cpi.0 as f64 / c.cpi.1 as f64 / nominal
    )
}

#[cfg(test)]
mod tests {
    use super::search;

    /// The cycle times [`search`] tries against a firmware that sustains `limit_ns` and more.
    fn tried(limit_ns: u64, resolution_ns: u64) -> Vec<u64> {
        let mut tried = Vec::new();
        search(resolution_ns, |ns| {
            tried.push(ns);
            ns >= limit_ns
        });
        tried
    }

    fn shortest(tried: &[u64], limit_ns: u64) -> Option<u64> {
        tried.iter().copied().filter(|&ns| ns >= limit_ns).min()
    }

    #[test]
    fn down_from_the_start_then_halving_the_gap() {
        let t = tried(82_000, 1_000);
        assert_eq!(&t[..2], [100_000, 80_000]);
        assert_eq!(shortest(&t, 82_000), Some(82_000));
        assert!(t.contains(&81_000), "the cycle just below is tried: {t:?}");
    }

    #[test]
    fn up_from_the_start_when_it_is_not_sustained() {
        let t = tried(103_000, 1_000);
        assert_eq!(&t[..2], [100_000, 125_000]);
        assert_eq!(shortest(&t, 103_000), Some(103_000));
        assert!(t.contains(&102_000), "{t:?}");
        let t = tried(180_000, 5_000);
        assert_eq!(&t[..4], [100_000, 125_000, 150_000, 200_000]);
        assert_eq!(shortest(&t, 180_000), Some(180_000));
    }

    #[test]
    fn nothing_sustained_ends_the_search() {
        let t = tried(u64::MAX, 1_000);
        assert_eq!(t.len(), 1 + super::SWEEP_UP_US.len());
        assert_eq!(shortest(&t, u64::MAX), None);
    }
}
