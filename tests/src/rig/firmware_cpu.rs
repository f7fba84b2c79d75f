//! The firmware's own PDI task ([`firmware::stacks::ethercat::pdi_task::PdiTask`] around the
//! [`firmware::stacks::ethercat::SlaveApp`]), DAC task ([`firmware::io::analog::dac::OutputDac`] with the
//! [`DacLatch`]) and ADC scan ([`firmware::platform::adc_scan::SCAN_CONFIG`]) running on the
//! board's models through the real driver crates, with the interrupts in priority order on
//! virtual time:
//!
//! | board event        | firmware task (priority)  | here                                         |
//! |--------------------|---------------------------|----------------------------------------------|
//! | SYNC0 edge         | DAC task (highest)        | [`DacLatch::on_sync0`] -> `OutputDac` (LDAC pulse or two frames) |
//! | ESC IRQ line       | PDI task (middle)         | `PdiTask::run` (edge), then the DAC task if pended |
//! | after every event  | PDI task background       | `PdiTask::run` (poll)                        |
//! | SysTick (1 ms)     | `tick` -> PDI task        | `PdiTask::run` (poll)                        |
//! | PDI task asked for the mailbox | mailbox task (lowest) | `PdiTask::mailbox_step` until done, right after the PDI task |
//! | ADC timer (4 us)   | CNV timer + SSP (hardware)| one `ad7689` frame, the sample queued for the PDI task |
//! | CAN frame received, CAN node deadline, PDI task left CAN work | CAN task (same priority as the PDI task) | [`firmware::stacks::canopen::task::run`] on the board's CAN bus ([`BusController`]) |
//!
//! Power-up follows the firmware's `init`: the DAC is set up first, then `init` waits for
//! the ESC's EEPROM_LOADED pin, polled every 100 us for at most [`INIT_EEPROM_WAIT_NS`]
//! (nothing else runs meanwhile), and reports a timeout ([`FirmwareStats::init_pdi_ready`]);
//! then the ADC timer and the tick start, and the PDI task starts the application whenever
//! the pin is up.
//!
//! The drivers are the ones the board runs:
//! - ESC: `et1100::Et1100<SpiPdi<EscSpi>>` over the byte-exact SPI model: the type the
//!   board has with its legacy SPI in place of `EscSpi` (`firmware/src/platform/hw/esc.rs`), and the
//!   same driver calls, since the application is generic over the driver's `Pdi`.
//! - DAC: `ad5663::Ad5663` inside the firmware's `OutputDac`, on the DAC model's SPI port
//!   with the LDAC pin model.
//! - ADC: `ad7689::Ad7689` (read after conversion, CNV = chip select) on the ADC model; the
//!   driver tracks the CFG pipeline and tags every sample with its channel. (The board's
//!   sampler pushes the same frames from a timer interrupt without the driver's
//!   `SpiDevice` path; the CFG word is the same constant.)
//!
//! DC mode uses the fast path of the brief: when new outputs arrive, the DAC task stages
//! both input registers (LDAC register 0: nothing changes), and the SYNC0 task only
//! pulses LDAC, so both channels change together at the edge.

use crate::models::adc::AdcSpi;
use crate::models::can::{PortId, SharedCanBus};
use crate::models::dac::{DacSpi, LdacPin};
use crate::models::esc::SyncEdge;
use crate::models::spi::EscSpi;
use crate::rig::board::{BoardIo, PdiCpu};
use ad7689::Ad7689;
use coe_core::canopen::CanFrame;
use et1100::{Et1100, SpiPdi};
use firmware::io::analog::dac::OutputDac;
use firmware::io::analog::outputs::{DacAction, DacLatch, OutputStage};
use firmware::io::analog::sampler::{Sample, Sampler};
use firmware::io::analog::AnalogApplication;
use firmware::platform::adc_scan::SCAN_CONFIG;
use firmware::products::{analog_io, analog_io_can, Product};
use firmware::stacks::canopen::task::{self as can_task, CanController, CanHost, CanInbox};
use firmware::stacks::ethercat::pdi_task::{Done, PdiTask, Wake, EEPROM_WAIT_MS};
use firmware::stacks::ethercat::{AppConfig, Application, SlaveApp};

/// A product as the board runs it: which one, its CANopen node-ID where it has CAN, and the
/// SII image the board's EEPROM holds ([`Device::of`]).
#[derive(Clone)]
pub struct Device {
    /// For the user.
    pub description: String,
    /// The product.
    pub product: &'static Product,
    /// The CANopen node-ID (products with CAN).
    pub node_id: u8,
    /// The SII EEPROM image.
    pub sii: Vec<u8>,
    /// The product's tasks at power-up.
    tasks: PowerUp,
}

impl Device {
    /// `product` with the CANopen node-ID `node_id`, on a board whose EEPROM holds `sii`;
    /// an error for a product the harness does not run.
    pub fn of(
        product: &'static Product,
        node_id: u8,
        sii: Vec<u8>,
        description: String,
    ) -> Result<Self, String> {
        Ok(Self {
            description,
            product,
            node_id,
            sii,
            tasks: tasks_of(product)?,
        })
    }

    /// The same module running the application of `product` (an update installed another
    /// product's image; the EEPROM keeps its SII).
    pub fn running(&self, product: &'static Product) -> Result<Self, String> {
        Ok(Self {
            product,
            tasks: tasks_of(product)?,
            ..self.clone()
        })
    }
}

/// The ESC as the application sees it.
type Esc = Et1100<SpiPdi<EscSpi>>;

/// What the harness needs of a product's application beyond the slave application's: how
/// it powers up, and the CAN task's host where the product has a CANopen node.
pub trait HostedApplication:
    Application<Stage = OutputStage> + AnalogApplication + Sized + 'static
{
    /// The slave application's configuration.
    const CONFIG: AppConfig;
    /// The application at power-up.
    fn power_up(node_id: u8) -> Self;
    /// The CAN task's host, if the product runs a CANopen node.
    fn can_host(app: &mut SlaveApp<Self>) -> Option<&mut dyn CanHost<Stage = OutputStage>>;
    /// The node as the tasks look at it, if the product has one.
    fn can_state(app: &SlaveApp<Self>, now_ns: u64) -> Option<CanState>;
}

/// The CANopen node as the harness's tasks see it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CanState {
    /// Frames wait for the controller.
    pub has_tx: bool,
    /// A call the window refused fits now.
    pub work_waiting: bool,
    /// A call the window refused waits.
    pub waiting: bool,
    /// When the node's timers must run (ns).
    pub deadline_ns: Option<u64>,
}

impl HostedApplication for analog_io::Application {
    const CONFIG: AppConfig = analog_io::CONFIG;

    fn power_up(_: u8) -> Self {
        analog_io::application()
    }

    fn can_host(_: &mut SlaveApp<Self>) -> Option<&mut dyn CanHost<Stage = OutputStage>> {
        None
    }

    fn can_state(_: &SlaveApp<Self>, _: u64) -> Option<CanState> {
        None
    }
}

impl HostedApplication for analog_io_can::Application {
    const CONFIG: AppConfig = analog_io_can::CONFIG;

    fn power_up(node_id: u8) -> Self {
        analog_io_can::application_with_node_id(node_id)
    }

    fn can_host(app: &mut SlaveApp<Self>) -> Option<&mut dyn CanHost<Stage = OutputStage>> {
        Some(app)
    }

    fn can_state(app: &SlaveApp<Self>, now_ns: u64) -> Option<CanState> {
        let can = &app.application().can;
        Some(CanState {
            has_tx: can.has_tx(),
            work_waiting: can.work_waiting(now_ns),
            waiting: can.waiting(),
            deadline_ns: can.deadline_ns(),
        })
    }
}

/// How a product's tasks start, with the CANopen node-ID.
type PowerUp = fn(u8) -> Box<dyn Tasks>;

/// A product's PDI task (and its CAN task's host), behind one interface.
pub trait Tasks {
    fn start(&mut self, esc: &mut Esc, ready: bool) -> bool;
    fn started(&self) -> bool;
    fn bus_errors(&self) -> u32;
    fn run(
        &mut self,
        esc: &mut Esc,
        stage: &OutputStage,
        now_ns: u64,
        wake: Wake,
        still_asserted: &mut dyn FnMut() -> bool,
        drain: &mut dyn FnMut(&mut Sampler),
    ) -> Done;
    fn can_host(&mut self) -> Option<&mut dyn CanHost<Stage = OutputStage>>;
    fn can_state(&self, now_ns: u64) -> Option<CanState>;
}

impl<A: HostedApplication> Tasks for PdiTask<A> {
    fn start(&mut self, esc: &mut Esc, ready: bool) -> bool {
        PdiTask::start(self, esc, ready)
    }

    fn started(&self) -> bool {
        PdiTask::started(self)
    }

    fn bus_errors(&self) -> u32 {
        PdiTask::bus_errors(self)
    }

    fn run(
        &mut self,
        esc: &mut Esc,
        stage: &OutputStage,
        now_ns: u64,
        wake: Wake,
        still_asserted: &mut dyn FnMut() -> bool,
        drain: &mut dyn FnMut(&mut Sampler),
    ) -> Done {
        let mut done = PdiTask::run(self, esc, stage, now_ns, wake, still_asserted, |app| {
            drain(&mut app.analog().sampler)
        });
        // The mailbox task (below the PDI task) runs its steps before the harness's next
        // event: the host-compiled firmware takes no time.
        if core::mem::take(&mut done.serve_mailbox) {
            done.apply_outputs |= PdiTask::serve_mailbox(self, esc, stage, now_ns);
        }
        done
    }

    fn can_host(&mut self) -> Option<&mut dyn CanHost<Stage = OutputStage>> {
        A::can_host(self.app_mut())
    }

    fn can_state(&self, now_ns: u64) -> Option<CanState> {
        A::can_state(self.app(), now_ns)
    }
}

/// How the tasks of `product` start (the products the virtual board runs: the analog ones).
fn tasks_of(product: &Product) -> Result<PowerUp, String> {
    fn task<A: HostedApplication>(node_id: u8) -> Box<dyn Tasks> {
        Box::new(PdiTask::new(SlaveApp::new(A::CONFIG, A::power_up(node_id))))
    }
    let name = product.name;
    if name == analog_io::PRODUCT.name {
        Ok(task::<analog_io::Application>)
    } else if name == analog_io_can::PRODUCT.name {
        Ok(task::<analog_io_can::Application>)
    } else {
        Err(format!(
            "the virtual board does not run the product {name:?}"
        ))
    }
}

/// Frames after power-up whose results are discarded: two carry the CFG, the third may
/// still hold a conversion under the power-up CFG (as `Ad7689::start` does it).
const ADC_START_FRAMES: u64 = 3;

/// Transmit buffers of the LPC1754's CAN controller (TFI1..3).
pub const CAN_TX_BUFFERS: usize = 3;

/// The MCU's CAN controller on the board's bus: received frames wait in the port, and a
/// frame is taken for transmission while fewer than [`CAN_TX_BUFFERS`] wait to go out.
pub struct BusController {
    bus: SharedCanBus,
    port: PortId,
}

impl CanController for BusController {
    fn receive(&mut self) -> Option<CanFrame> {
        self.bus.borrow_mut().receive(self.port).map(|(_, f)| f)
    }

    fn transmit(&mut self, frame: &CanFrame) -> bool {
        let mut bus = self.bus.borrow_mut();
        if bus.pending(self.port) >= CAN_TX_BUFFERS {
            return false;
        }
        bus.send(self.port, *frame);
        true
    }
}

/// The firmware's SysTick period: the PDI task's background work is requested this often.
pub const TICK_NS: u64 = 1_000_000;

/// How long the firmware's `init` waits for EEPROM_LOADED.
pub const INIT_EEPROM_WAIT_NS: u64 = EEPROM_WAIT_MS as u64 * 1_000_000;

/// Most activations of the CAN task in a row: a bound, so a flooded bus cannot stop virtual
/// time; frames left are served at the next CAN event.
const MAX_CAN_RUNS: usize = 16;

/// How often `init` looks at the pin while it waits.
const INIT_POLL_NS: u64 = 100_000;

/// Counters of the harness.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct FirmwareStats {
    /// AD7689 frames clocked.
    pub adc_frames: u64,
    /// Samples handed to the application.
    pub samples: u64,
    /// SYNC0 edges that changed the outputs.
    pub sync0_pulses: u64,
    /// SYNC0 edges that kept the outputs (no fresh pair).
    pub sync0_keep: u64,
    /// DAC or ADC driver errors; none are expected on the models (ESC errors:
    /// [`FirmwareCpu::esc_bus_errors`]).
    pub driver_errors: u64,
    /// What `init` found after its wait: `Some(true)` EEPROM_LOADED was up, `Some(false)`
    /// the wait timed out (the firmware logs "ET1100 PDI not ready"), `None` still waiting.
    pub init_pdi_ready: Option<bool>,
    /// Virtual time `init` ended (ns).
    pub init_done_ns: u64,
    /// Ticks (the PDI task's periodic background work).
    pub ticks: u64,
}

/// The firmware's tasks as the board's PDI-side CPU.
pub struct FirmwareCpu {
    esc: Esc,
    dac: OutputDac<DacSpi, LdacPin>,
    adc: Ad7689<AdcSpi>,
    task: Box<dyn Tasks>,
    stage: OutputStage,
    latch: DacLatch,
    pending: Vec<Sample>,
    adc_period_ns: u64,
    next_cnv_ns: u64,
    next_tick_ns: u64,
    /// While `init` waits for EEPROM_LOADED: its next look at the pin, and when it gives up.
    init_wait: Option<(u64, u64)>,
    bootloader_requested: bool,
    can: BusController,
    /// The CAN task's received frames while its window is closed.
    can_inbox: CanInbox,
    /// Counters.
    pub stats: FirmwareStats,
}

impl FirmwareCpu {
    /// Power-up: the DAC gets the firmware's init sequence (reset, both channels powered,
    /// LDAC register 0); `init` waits for EEPROM_LOADED (bounded); then the ADC's
    /// conversion timer runs at `adc_period_ns` (4000 = 250 kSPS) and its first two frames
    /// write the scan CFG, and the PDI task starts the application (AL status INIT, event
    /// mask) once the ESC's PDI is operational.
    pub fn new(io: BoardIo, device: &Device, adc_period_ns: u64) -> Self {
        let task = (device.tasks)(device.node_id);
        let Ok(dac) = OutputDac::new(io.dac.clone(), io.ldac.clone());
        let mut cpu = Self {
            esc: Et1100::new(SpiPdi::new(io.esc.clone())),
            dac,
            adc: Ad7689::new(io.adc.clone()),
            task,
            stage: OutputStage::new(),
            latch: DacLatch::new(),
            pending: Vec::new(),
            adc_period_ns: adc_period_ns.max(1),
            next_cnv_ns: 0,
            next_tick_ns: 0,
            init_wait: Some((io.now_ns(), io.now_ns() + INIT_EEPROM_WAIT_NS)),
            bootloader_requested: false,
            can: BusController {
                bus: io.can.bus.clone(),
                port: io.can.port,
            },
            can_inbox: CanInbox::new(),
            stats: FirmwareStats::default(),
        };
        let ok = cpu.dac.init().is_ok();
        cpu.count(ok);
        if pdi_ready(&io) {
            cpu.finish_init(&io, true);
        }
        cpu
    }

    /// `init` ends: the PDI task starts the application if the PDI is ready, the ADC timer
    /// and the tick start.
    fn finish_init(&mut self, io: &BoardIo, ready: bool) {
        self.init_wait = None;
        self.stats.init_pdi_ready = Some(ready);
        self.stats.init_done_ns = io.now_ns();
        self.task.start(&mut self.esc, ready);
        self.next_cnv_ns = io.now_ns() + self.adc_period_ns;
        self.next_tick_ns = io.now_ns() + TICK_NS;
        // The CAN node's first activation (its boot-up message) as soon as interrupts run,
        // so its due deadline is not left behind `init`.
        self.can_task(io);
    }

    /// Whether `init` still runs (interrupts are not taken yet).
    pub fn in_init(&self) -> bool {
        self.init_wait.is_some()
    }

    /// Whether the PDI task has started the application.
    pub fn started(&self) -> bool {
        self.task.started()
    }

    /// The output stage shared by the PDI and DAC tasks.
    pub fn stage(&self) -> &OutputStage {
        &self.stage
    }

    /// True once the PDI task asked for the reset into the bootloader (a master's INIT ->
    /// BOOT): the board's firmware sets the boot request word and resets the CPU there
    /// ([`crate::rig::module_cpu::ModuleCpu`] does it).
    pub fn bootloader_requested(&self) -> bool {
        self.bootloader_requested
    }

    /// ESC accesses that failed in the PDI task.
    pub fn esc_bus_errors(&self) -> u32 {
        self.task.bus_errors()
    }

    fn count(&mut self, ok: bool) {
        if !ok {
            self.stats.driver_errors += 1;
        }
    }

    /// The DAC task pended by the PDI task: apply the staged pair now, or (DC mode) write
    /// a freshly staged pair into the input registers for the next SYNC0 edge.
    fn dac_task(&mut self, done: Done) {
        let ok = if done.apply_outputs {
            let a = self.latch.apply_now(&self.stage);
            self.dac.execute(a).is_ok()
        } else if done.preload_outputs {
            match self.latch.preload(&self.stage) {
                Some(pair) => self.dac.preload(pair).is_ok(),
                None => true,
            }
        } else {
            true
        };
        self.count(ok);
    }

    /// One activation of the PDI task.
    fn pdi_task(&mut self, io: &BoardIo, edge: bool) {
        let wake = Wake {
            edge,
            line_asserted: edge,
            poll: !edge,
            pdi_ready: pdi_ready(io),
        };
        let line = io.esc.clone();
        let (pending, stats) = (&mut self.pending, &mut self.stats);
        // The samples move where the firmware's task drains its ring (`PdiTask::run`).
        let drain = |sampler: &mut Sampler| {
            stats.samples += pending.len() as u64;
            sampler.add_all(pending);
            pending.clear();
        };
        let mut drain = drain;
        let done = self.task.run(
            &mut self.esc,
            &self.stage,
            io.now_ns(),
            wake,
            &mut || line.irq(),
            &mut drain,
        );
        // The board calls `on_irq` again while the line stays asserted (bounded), which
        // is what `pend_again` asks for.
        self.dac_task(done);
        self.bootloader_requested |= done.enter_bootloader;
        // The PDI task pends the CAN task when it left CAN work (an Emergency to send).
        if self.can_due(io.now_ns()) {
            self.can_task(io);
        }
    }

    /// True if the CAN node has frames for the controller, its deadline has come, or the
    /// CAN window has opened on work it held back.
    fn can_due(&self, now_ns: u64) -> bool {
        self.task.can_state(now_ns).is_some_and(|s| {
            s.has_tx || s.work_waiting || (!s.waiting && s.deadline_ns.is_some_and(|t| t <= now_ns))
        })
    }

    /// The CAN task, activated again while it asks to (one received frame each), at most
    /// [`MAX_CAN_RUNS`] times in a row.
    fn can_task(&mut self, io: &BoardIo) {
        for _ in 0..MAX_CAN_RUNS {
            let Some(host) = self.task.can_host() else {
                return;
            };
            let out = can_task::run(
                &mut self.can,
                &mut self.can_inbox,
                host,
                &self.stage,
                io.now_ns(),
            );
            self.dac_task(Done {
                apply_outputs: out.apply_outputs,
                ..Done::default()
            });
            if !out.run_again {
                break;
            }
        }
    }
}

/// EEPROM_LOADED: the ESC's PDI works once it has loaded a good SII.
fn pdi_ready(io: &BoardIo) -> bool {
    io.esc.esc().borrow().pdi_operational()
}

impl PdiCpu for FirmwareCpu {
    fn as_any(&self) -> Option<&dyn std::any::Any> {
        Some(self)
    }

    fn on_sync0(&mut self, _io: &mut BoardIo, edge: &SyncEdge) {
        if self.in_init() {
            return;
        }
        let a = self.latch.on_sync0(&self.stage, edge.time_ns);
        match a {
            DacAction::Keep => self.stats.sync0_keep += 1,
            _ => self.stats.sync0_pulses += 1,
        }
        let ok = self.dac.execute(a).is_ok();
        self.count(ok);
    }

    fn on_irq(&mut self, io: &mut BoardIo) {
        if !self.in_init() {
            self.pdi_task(io, true);
        }
    }

    fn poll(&mut self, io: &mut BoardIo) {
        if !self.in_init() {
            self.pdi_task(io, false);
        }
    }

    fn on_can_rx(&mut self, io: &mut BoardIo) {
        // Frames that arrive while `init` runs wait in the controller for the CAN task.
        if !self.in_init() {
            self.can_task(io);
        }
    }

    fn next_timer_ns(&self) -> Option<u64> {
        match self.init_wait {
            Some((poll, deadline)) => Some(poll.min(deadline)),
            None => {
                let next = self.next_cnv_ns.min(self.next_tick_ns);
                // Work the CAN window held back waits for the PDI task or the tick.
                let can = self
                    .task
                    .can_state(0)
                    .and_then(|s| s.deadline_ns.filter(|_| !s.waiting));
                Some(can.map_or(next, |t| t.min(next)))
            }
        }
    }

    /// `init`'s pin poll while it waits; afterwards the CAN node's deadline, the tick (the
    /// PDI task's background work) and the CNV timer.
    fn on_timer(&mut self, io: &mut BoardIo) {
        let now = io.now_ns();
        if let Some((poll, deadline)) = self.init_wait {
            if pdi_ready(io) || now >= deadline {
                self.finish_init(io, pdi_ready(io));
            } else {
                self.init_wait = Some((poll.max(now) + INIT_POLL_NS, deadline));
            }
            return;
        }
        if self.can_due(now) {
            self.can_task(io);
        }
        if now >= self.next_tick_ns {
            self.stats.ticks += 1;
            self.next_tick_ns = now.max(self.next_tick_ns) + TICK_NS;
            self.pdi_task(io, false);
        }
        if now >= self.next_cnv_ns {
            self.adc_frame(io);
        }
    }
}

impl FirmwareCpu {
    /// One CNV period: one AD7689 frame (the timer paces them at `adc_period_ns`, so the
    /// driver's own `wait_ready` is not needed). The first frames run the driver's
    /// start-up sequence; after that every result comes tagged with its input.
    fn adc_frame(&mut self, io: &BoardIo) {
        let k = self.stats.adc_frames;
        self.stats.adc_frames += 1;
        let result = if k < ADC_START_FRAMES - 1 {
            self.adc.read_and_configure(SCAN_CONFIG)
        } else {
            self.adc.read()
        };
        match result {
            Ok(Some(s)) if k >= ADC_START_FRAMES => {
                if let Some(ch) = s.channel.input() {
                    self.pending.push(Sample::new(ch, s.code));
                }
            }
            Ok(_) => {}
            Err(_) => self.stats.driver_errors += 1,
        }
        self.next_cnv_ns = io.now_ns().max(self.next_cnv_ns) + self.adc_period_ns;
    }
}
