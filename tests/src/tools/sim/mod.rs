//! `cargo xtask sim`: the virtual board driven by a real master.
//!
//! Two ways to run it:
//! - [`run_in_process`]: ethercrab in the same process ([`crate::rig::master::tx_rx_task`]),
//!   on virtual time. It walks the ESM (printing each state), reads the identity and an
//!   object dictionary summary over SDO, then runs the thesis loop-back experiment: a sine
//!   into an analog input, the master copies that input to an analog output every cycle,
//!   and the DAC model's output is analysed ([`crate::tools::loopback`]).
//! - [`run_wall_clock`]: the board on wall-clock time for masters outside the process: on a
//!   Linux network interface ([`crate::tools::iface`]) for any EtherCAT master, and/or on
//!   its CAN bus through a socketcand server ([`crate::tools::socketcand`]) for any CANopen
//!   master (python-canopen through python-can's `socketcand` interface).
//!
//! What runs on the board's PDI side is a [`Target`]: the firmware's slave application
//! ([`firmware_target`]) or the transport test responder ([`responder::EchoResponder`]).

pub mod cli;
pub mod firmware_device;
pub mod responder;
pub mod tshark;

use crate::models::adc::Signal;
use crate::models::dac::DacUpdate;
use crate::rig::board::{BoardConfig, BoardIo, PdiCpu, VirtualBoard};
use crate::rig::master::tx_rx_task;
use crate::tools::iface::{self, RawSocket, ServeOptions, ServeStats};
use crate::tools::loopback::{self, Analysis, AnalysisOptions};
use crate::tools::socketcand::{SocketcandServer, BUS_NAME};
use ethercrab::std::ethercat_now;
use ethercrab::subdevice_group::DcConfiguration;
use ethercrab::{
    DcSync, MainDevice, MainDeviceConfig, ObjectDescriptionListQuery, PduStorage, SubDeviceRef,
    SubDeviceState,
};
use std::cell::RefCell;
use std::fmt;
use std::path::PathBuf;
use std::rc::Rc;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

/// Shortest cycle time accepted (us). Below it a cycle's LRW + FRMW frame no longer fits
/// between two SYNC0 edges with the PDI work of the slave.
pub const MIN_CYCLE_US: u32 = 25;
/// Longest cycle time accepted (us): 0x1C32:02 and 0x09A0 are 32-bit nanoseconds.
pub const MAX_CYCLE_US: u32 = 4_000_000;
/// Largest `--slowdown`: a 1 ms cycle is then a 1 s cycle on the wall clock.
pub const MAX_SLOWDOWN: u32 = 1000;
/// Default cycle time (us): the module's advertised minimum (0x1C32:05), the shortest DC
/// cycle it accepts.
pub const DEFAULT_CYCLE_US: u32 = firmware::products::analog_io::sync::MIN_CYCLE_TIME_NS / 1000;
/// Default frequencies of the loop-back experiment (the thesis: 50 Hz, 500 Hz, 1 kHz).
pub const DEFAULT_FREQS_HZ: [f64; 3] = [50.0, 500.0, 1000.0];
/// Default virtual time of the loop-back, per frequency (s): 5 periods at 50 Hz.
pub const DEFAULT_SECONDS: f64 = 0.1;
/// Input sine: 5 V offset +- 4 V, i.e. 8 V peak-to-peak inside the 0..10 V range (the
/// thesis' "峰值为 8V" sine, whose outputs it reports as "峰峰值 ... 8V").
pub const DEFAULT_AMPLITUDE_V: f64 = 4.0;
/// Offset of the input sine (V).
pub const DEFAULT_OFFSET_V: f64 = 5.0;

/// The CANopen node-ID unless configured (of the products with CAN).
pub const DEFAULT_NODE_ID: u8 = firmware::products::analog_io_can::can::DEFAULT_NODE_ID;

/// What `cargo xtask sim` does.
#[derive(Clone, Debug, PartialEq)]
pub struct SimConfig {
    /// Process-data / SYNC0 cycle time (us).
    pub cycle_us: u32,
    /// In process: virtual seconds of loop-back per frequency. On an interface: wall
    /// seconds to serve (None: until Ctrl-C).
    pub seconds: Option<f64>,
    /// Loop-back input frequencies (Hz).
    pub freqs_hz: Vec<f64>,
    /// Input sine amplitude (V).
    pub amplitude_v: f64,
    /// Input sine offset (V).
    pub offset_v: f64,
    /// Analog input fed with the sine (0..=7, i.e. 0x6401:01..08).
    pub ai_channel: u8,
    /// Analog output the master copies it to (0..=1, i.e. 0x6411:01..02).
    pub ao_channel: u8,
    /// On the wall clock: constant voltages at the analog inputs (V, 0..10), channel by
    /// channel, in place of the sine on its own channel; `None` leaves a channel as it is
    /// (the sine's, or 0 V). A master outside the process can then check every input's value.
    pub ai_levels_v: [Option<f64>; 8],
    /// Write the traffic to this pcap file.
    pub pcap: Option<PathBuf>,
    /// Attach to this network interface instead of the in-process master.
    pub iface: Option<String>,
    /// Serve the CAN bus through socketcand on this TCP port (wall-clock time).
    pub can_port: Option<u16>,
    /// CAN bit rate (bit/s, one of [`can_bit_rates`]).
    pub can_bit_rate: u32,
    /// The module's CANopen node-ID (1..=127).
    pub node_id: u8,
    /// On the wall clock: the board's time runs this many times slower than the wall clock
    /// (1: real time; [`ServeOptions::slowdown`]).
    pub slowdown: u32,
}

impl Default for SimConfig {
    fn default() -> Self {
        Self {
            cycle_us: DEFAULT_CYCLE_US,
            seconds: None,
            freqs_hz: DEFAULT_FREQS_HZ.to_vec(),
            amplitude_v: DEFAULT_AMPLITUDE_V,
            offset_v: DEFAULT_OFFSET_V,
            ai_channel: 0,
            ao_channel: 0,
            ai_levels_v: [None; 8],
            pcap: None,
            iface: None,
            can_port: None,
            can_bit_rate: crate::rig::board::DEFAULT_CAN_BIT_RATE,
            node_id: DEFAULT_NODE_ID,
            slowdown: 1,
        }
    }
}

/// A configuration error, with a message for the user.
#[derive(Clone, Debug, PartialEq)]
pub struct ConfigError(pub String);

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for ConfigError {}

impl SimConfig {
    /// Checks the values (ranges, the sine inside 0..10 V, frequencies below the cycle's
    /// Nyquist rate).
    pub fn validate(&self) -> Result<(), ConfigError> {
        let err = |s: String| Err(ConfigError(s));
        if self.cycle_us < MIN_CYCLE_US {
            return err(format!(
                "--cycle-us {}: the cycle time must be at least {MIN_CYCLE_US} us",
                self.cycle_us
            ));
        }
        if self.cycle_us > MAX_CYCLE_US {
            return err(format!(
                "--cycle-us {}: the cycle time must be at most {MAX_CYCLE_US} us",
                self.cycle_us
            ));
        }
        if let Some(s) = self.seconds {
            if !(s.is_finite() && s > 0.0) {
                return err(format!("--seconds {s}: must be a positive number"));
            }
            if !self.wall_clock() && s > 60.0 {
                return err(format!(
                    "--seconds {s}: at most 60 s of virtual time per frequency in process"
                ));
            }
        }
        if self.freqs_hz.is_empty() {
            return err("--freq: give at least one frequency".into());
        }
        let nyquist = 1e6 / self.cycle_us as f64 / 2.0;
        for &f in &self.freqs_hz {
            if !(f.is_finite() && f > 0.0) {
                return err(format!("--freq {f}: must be a positive frequency in Hz"));
            }
            if f >= nyquist {
                return err(format!(
                    "--freq {f}: must be below half the cycle rate ({nyquist} Hz at {} us)",
                    self.cycle_us
                ));
            }
            if !self.wall_clock() {
                let secs = self.loopback_seconds();
                if secs * f < 1.0 {
                    return err(format!(
                        "--seconds {secs}: shorter than one period of {f} Hz"
                    ));
                }
            }
        }
        let (lo, hi) = (
            self.offset_v - self.amplitude_v.abs(),
            self.offset_v + self.amplitude_v.abs(),
        );
        if !(lo >= 0.0 && hi <= 10.0) {
            return err(format!(
                "the input sine {} V +- {} V leaves the 0..10 V input range",
                self.offset_v, self.amplitude_v
            ));
        }
        if self.ai_channel > 7 {
            return err(format!(
                "analog input {} does not exist (0..=7)",
                self.ai_channel
            ));
        }
        for (ch, v) in self.ai_levels_v.iter().enumerate() {
            if let Some(v) = *v {
                if !(0.0..=10.0).contains(&v) {
                    return err(format!(
                        "analog input {ch}: {v} V is outside the 0..10 V input range"
                    ));
                }
            }
        }
        if self.ao_channel > 1 {
            return err(format!(
                "analog output {} does not exist (0..=1)",
                self.ao_channel
            ));
        }
        if !can_bit_rates().any(|r| r == self.can_bit_rate) {
            return err(format!(
                "--can-bit-rate {}: the module's CAN controller runs at {} bit/s",
                self.can_bit_rate,
                can_bit_rates()
                    .map(|r| r.to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
        if !(1..=127).contains(&self.node_id) {
            return err(format!(
                "--node-id {}: a CANopen node-ID is 1..=127",
                self.node_id
            ));
        }
        if !(1..=MAX_SLOWDOWN).contains(&self.slowdown) {
            return err(format!(
                "--slowdown {}: 1 (real time) ..= {MAX_SLOWDOWN}",
                self.slowdown
            ));
        }
        if self.slowdown > 1 && self.can_port.is_some() {
            return err(format!(
                "--slowdown {}: not with --can-port (socketcand's clients keep the wall \
                 clock's CAN timing)",
                self.slowdown
            ));
        }
        if self.slowdown > 1 && self.iface.is_none() {
            return err(format!(
                "--slowdown {}: slows the board for a master on --iface; in process the \
                 board's time is virtual anyway",
                self.slowdown
            ));
        }
        Ok(())
    }

    /// True when the board runs on the wall clock for masters outside the process
    /// (`--iface` and/or `--can-port`).
    pub fn wall_clock(&self) -> bool {
        self.iface.is_some() || self.can_port.is_some()
    }

    /// Virtual seconds of loop-back per frequency (in process).
    pub fn loopback_seconds(&self) -> f64 {
        self.seconds.unwrap_or(DEFAULT_SECONDS)
    }

    /// The cycle time in ns.
    pub fn cycle_ns(&self) -> u64 {
        self.cycle_us as u64 * 1000
    }
}

/// The CAN bit rates of the module (bit/s): those its EDS lists (the firmware's driver has
/// an exact bit timing for each).
pub fn can_bit_rates() -> impl Iterator<Item = u32> {
    coe_core::eds::BIT_RATES_KBIT
        .iter()
        .zip(firmware::products::analog_io_can::can::EDS_INFO.bit_rates)
        .filter(|(_, on)| *on)
        .map(|(kbit, _)| u32::from(*kbit) * 1000)
}

/// What runs on the PDI side of the board, with its SII image.
pub struct Target {
    /// What it is, for the user.
    pub description: String,
    /// The SII EEPROM image.
    pub sii: Vec<u8>,
    /// Builds the CPU from the board's peripherals.
    pub make_cpu: Box<dyn FnOnce(BoardIo) -> Box<dyn PdiCpu>>,
}

impl Target {
    /// The transport test responder on the test SII (no CoE; SM2 word echoed into SM3).
    pub fn echo() -> Self {
        Self {
            description: "echo responder (test SII, no CoE; not the firmware)".into(),
            sii: crate::rig::sii_builder::minimal_io_device(),
            make_cpu: Box::new(|_| Box::new(responder::EchoResponder::new())),
        }
    }

    /// A board with this target as its CPU, on the board configuration for its SII image
    /// as `configure` adjusts it.
    pub fn into_board(self, configure: impl FnOnce(&mut BoardConfig)) -> VirtualBoard {
        let mut cfg = BoardConfig::new(self.sii);
        configure(&mut cfg);
        let mut board = VirtualBoard::new(cfg);
        let cpu = (self.make_cpu)(board.io());
        board.set_cpu(cpu);
        board
    }
}

/// The default product's slave application on the board, with its generated SII image.
pub fn firmware_target() -> Result<Target, String> {
    firmware_target_of(firmware::products::default(), DEFAULT_NODE_ID)
}

/// `product`'s slave application on the board, with the CANopen node-ID `node_id` where it
/// has CAN.
pub fn firmware_target_of(
    product: &'static firmware::products::Product,
    node_id: u8,
) -> Result<Target, String> {
    let device = firmware_device::device_of(product, node_id)?;
    Ok(Target {
        description: device.description.clone(),
        sii: device.sii.clone(),
        make_cpu: Box::new(move |io| {
            Box::new(crate::rig::firmware_cpu::FirmwareCpu::new(
                io,
                &device,
                crate::models::adc::T_CYC_NS,
            ))
        }),
    })
}

/// A line of output: results go to stdout, progress to stderr.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Line {
    /// A result (ESM state, identity, SDO value, loop-back figures).
    Result(String),
    /// Progress.
    Progress(String),
}

/// A value read over SDO (or why it could not be read).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SdoValue {
    /// What it is.
    pub label: String,
    /// Index.
    pub index: u16,
    /// Subindex.
    pub sub: u8,
    /// The value as text, or the error.
    pub value: Result<String, String>,
}

/// Where one PDO entry sits in the process image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MappedEntry {
    /// Object index.
    pub index: u16,
    /// Subindex.
    pub sub: u8,
    /// Length in bits.
    pub bits: u8,
    /// Bit offset in the slave's input (TxPDO) or output (RxPDO) image.
    pub bit_offset: usize,
}

/// The PDO mapping as read by the master over SDO (0x1C12/0x1C13 and the PDOs).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct PdoLayout {
    /// RxPDOs assigned to SM2.
    pub rx_pdos: Vec<u16>,
    /// TxPDOs assigned to SM3.
    pub tx_pdos: Vec<u16>,
    /// Output entries (master -> slave).
    pub outputs: Vec<MappedEntry>,
    /// Input entries (slave -> master).
    pub inputs: Vec<MappedEntry>,
}

impl PdoLayout {
    /// The input entry for `index:sub`.
    pub fn input(&self, index: u16, sub: u8) -> Option<MappedEntry> {
        self.inputs
            .iter()
            .copied()
            .find(|e| e.index == index && e.sub == sub)
    }
    /// The output entry for `index:sub`.
    pub fn output(&self, index: u16, sub: u8) -> Option<MappedEntry> {
        self.outputs
            .iter()
            .copied()
            .find(|e| e.index == index && e.sub == sub)
    }
}

/// Object dictionary summary from SDO Information.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct OdSummary {
    /// All objects.
    pub all: Vec<u16>,
    /// RxPDO-mappable objects.
    pub rx_mappable: Vec<u16>,
    /// TxPDO-mappable objects.
    pub tx_mappable: Vec<u16>,
}

/// What an in-process run produced.
#[derive(Clone, Debug, Default)]
pub struct SimReport {
    /// What ran on the PDI side.
    pub target: String,
    /// ESM states reached, in order, as the master saw them.
    pub states: Vec<String>,
    /// Name from the SII.
    pub name: String,
    /// Identity from the SII (vendor, product, revision, serial).
    pub identity: (u32, u32, u32, u32),
    /// Values read over SDO.
    pub sdo: Vec<SdoValue>,
    /// Object dictionary summary (None: no CoE or no SDO Information).
    pub od: Option<Result<OdSummary, String>>,
    /// The PDO mapping read over SDO.
    pub pdo: Option<Result<PdoLayout, String>>,
    /// Loop-back figures per frequency.
    pub loopback: Vec<(f64, Result<Analysis, String>)>,
    /// Process-data cycles run.
    pub cycles: u64,
    /// Frames exchanged.
    pub frames: u64,
    /// Virtual time at the end (ns).
    pub virtual_ns: u64,
    /// Wall time of the run.
    pub wall: Duration,
    /// Where the pcap went, and how many frames it holds.
    pub pcap: Option<(PathBuf, usize)>,
    /// Every DAC load of the run (for plots of the loop-back; windows in `loopback`).
    pub dac_updates: Vec<crate::models::dac::DacUpdate>,
}

impl SimReport {
    /// Every loop-back of the run (made with `cfg`) judged against the zero-order hold
    /// ([`loopback::check_loopback`]); the figures and the first failure, if any.
    pub fn check_loopback(&self, cfg: &SimConfig) -> Result<Vec<Analysis>, String> {
        if self.loopback.is_empty() {
            return Err("no loop-back was run".into());
        }
        self.loopback
            .iter()
            .map(|(freq, a)| {
                let a = a
                    .as_ref()
                    .map_err(|e| format!("loop-back {freq} Hz: {e}"))?;
                let input = Signal::Sine {
                    amplitude: cfg.amplitude_v,
                    offset: cfg.offset_v,
                    freq_hz: *freq,
                    phase: 0.0,
                };
                let ideal = loopback::ideal_hold_analysis(
                    &input,
                    &self.dac_updates,
                    cfg.ao_channel,
                    a,
                    cfg.cycle_ns(),
                )
                .map_err(|e| format!("the ideal hold at {freq} Hz: {e}"))?;
                loopback::check_loopback(a, &ideal, cfg.cycle_ns())?;
                Ok(a.clone())
            })
            .collect()
    }
}

/// A failure that ends a run.
#[derive(Debug)]
pub struct SimError(pub String);

impl fmt::Display for SimError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for SimError {}

fn state_name(s: SubDeviceState) -> String {
    match s {
        SubDeviceState::Init => "INIT".into(),
        SubDeviceState::PreOp => "PRE-OP".into(),
        SubDeviceState::SafeOp => "SAFE-OP".into(),
        SubDeviceState::Op => "OP".into(),
        SubDeviceState::Bootstrap => "BOOT".into(),
        other => format!("{other:?}"),
    }
}

type Out<'a> = &'a mut dyn FnMut(Line);

async fn record_state(
    sd: &SubDeviceRef<'_, impl std::ops::Deref<Target = ethercrab::SubDevice>>,
    report: &mut SimReport,
    out: Out<'_>,
) {
    let text = match sd.status().await {
        Ok((s, code)) => {
            let name = state_name(s);
            report.states.push(name.clone());
            format!(
                "AL status: {name} (AL status code {:#06x})",
                u16::from(code)
            )
        }
        Err(e) => format!("AL status: unreadable ({e})"),
    };
    out(Line::Result(text));
}

async fn read_sdo<T>(
    sd: &SubDeviceRef<'_, impl std::ops::Deref<Target = ethercrab::SubDevice>>,
    index: u16,
    sub: u8,
) -> Result<T, String>
where
    T: ethercrab::EtherCrabWireReadSized,
{
    sd.sdo_read::<T>(index, sub)
        .await
        .map_err(|e| e.to_string())
}

async fn read_identity_sdos(
    sd: &SubDeviceRef<'_, impl std::ops::Deref<Target = ethercrab::SubDevice>>,
) -> Vec<SdoValue> {
    let mut v = Vec::new();
    let mut push = |label: &str, index, sub, value: Result<String, String>| {
        v.push(SdoValue {
            label: label.into(),
            index,
            sub,
            value,
        })
    };
    push(
        "device type",
        0x1000,
        0,
        read_sdo::<u32>(sd, 0x1000, 0)
            .await
            .map(|x| format!("{x:#010x}")),
    );
    push(
        "error register",
        0x1001,
        0,
        read_sdo::<u8>(sd, 0x1001, 0)
            .await
            .map(|x| format!("{x:#04x}")),
    );
    for (label, index) in [
        ("device name", 0x1008),
        ("hardware version", 0x1009),
        ("software version", 0x100A),
    ] {
        push(
            label,
            index,
            0,
            read_sdo::<heapless::String<128>>(sd, index, 0)
                .await
                .map(|s| format!("\"{s}\"")),
        );
    }
    for (sub, label) in [
        (1, "vendor ID"),
        (2, "product code"),
        (3, "revision"),
        (4, "serial number"),
    ] {
        push(
            label,
            0x1018,
            sub,
            read_sdo::<u32>(sd, 0x1018, sub)
                .await
                .map(|x| format!("{x:#010x}")),
        );
    }
    v
}

/// Reads the PDO assignment and mapping as the master sees them.
pub async fn read_pdo_layout(
    sd: &SubDeviceRef<'_, impl std::ops::Deref<Target = ethercrab::SubDevice>>,
) -> Result<PdoLayout, String> {
    // ethercrab's expedited uploads are typed: the counts (subindex 0) are UNSIGNED8, the
    // assigned PDOs UNSIGNED16, the mapping entries UNSIGNED32.
    read_pdo_layout_with(|index, sub| async move {
        match (index, sub) {
            (_, 0) => read_sdo::<u8>(sd, index, 0).await.map(u32::from),
            (0x1C12 | 0x1C13, _) => read_sdo::<u16>(sd, index, sub).await.map(u32::from),
            _ => read_sdo::<u32>(sd, index, sub).await,
        }
    })
    .await
}

/// Reads the PDO assignment (0x1C12/0x1C13) and the mapping of each assigned PDO with
/// `read(index, sub)`, one SDO upload each, and lays the entries out as the master packs
/// them.
pub async fn read_pdo_layout_with<F, Fut>(mut read: F) -> Result<PdoLayout, String>
where
    F: FnMut(u16, u8) -> Fut,
    Fut: std::future::Future<Output = Result<u32, String>>,
{
    let mut layout = PdoLayout::default();
    for (assign, is_out) in [(0x1C12u16, true), (0x1C13u16, false)] {
        let n = read(assign, 0).await?;
        let mut bit = 0usize;
        for i in 1..=n {
            let pdo = read(assign, i as u8).await? as u16;
            if is_out {
                layout.rx_pdos.push(pdo);
            } else {
                layout.tx_pdos.push(pdo);
            }
            let m = read(pdo, 0).await?;
            for j in 1..=m {
                let e = read(pdo, j as u8).await?;
                let entry = MappedEntry {
                    index: (e >> 16) as u16,
                    sub: (e >> 8) as u8,
                    bits: e as u8,
                    bit_offset: bit,
                };
                bit += entry.bits as usize;
                if is_out {
                    layout.outputs.push(entry);
                } else {
                    layout.inputs.push(entry);
                }
            }
        }
    }
    Ok(layout)
}

async fn read_od_summary(
    sd: &SubDeviceRef<'_, impl std::ops::Deref<Target = ethercrab::SubDevice>>,
) -> Option<Result<OdSummary, String>> {
    let list = |q| async move {
        sd.sdo_info_object_description_list(q)
            .await
            .map(|o| o.map(|v| v.to_vec()))
            .map_err(|e| e.to_string())
    };
    let all = match list(ObjectDescriptionListQuery::All).await {
        Ok(None) => return None,
        Ok(Some(v)) => v,
        Err(e) => return Some(Err(e)),
    };
    let rx = list(ObjectDescriptionListQuery::RxPdoMappable).await;
    let tx = list(ObjectDescriptionListQuery::TxPdoMappable).await;
    Some(match (rx, tx) {
        (Ok(rx), Ok(tx)) => Ok(OdSummary {
            all,
            rx_mappable: rx.unwrap_or_default(),
            tx_mappable: tx.unwrap_or_default(),
        }),
        (Err(e), _) | (_, Err(e)) => Err(e),
    })
}

fn get_i16(image: &[u8], bit_offset: usize) -> Option<i16> {
    let b = bit_offset / 8;
    Some(i16::from_le_bytes([*image.get(b)?, *image.get(b + 1)?]))
}

fn set_i16(image: &mut [u8], bit_offset: usize, v: i16) -> bool {
    let b = bit_offset / 8;
    match image.get_mut(b..b + 2) {
        Some(s) => {
            s.copy_from_slice(&v.to_le_bytes());
            true
        }
        None => false,
    }
}

fn hex_list(v: &[u16]) -> String {
    v.iter()
        .map(|x| format!("{x:#06x}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// Runs the board with ethercrab in process: ESM walk, identity and OD over SDO,
/// loop-back for each frequency, back to INIT. `out` receives the lines as they come.
pub fn run_in_process(
    cfg: &SimConfig,
    target: Target,
    out: Out<'_>,
) -> Result<SimReport, SimError> {
    cfg.validate().map_err(|e| SimError(e.to_string()))?;
    let wall = Instant::now();
    let mut bcfg = BoardConfig::new(target.sii);
    bcfg.capture = cfg.pcap.is_some();
    let board = Rc::new(RefCell::new(VirtualBoard::new(bcfg)));
    let cpu = (target.make_cpu)(board.borrow().io());
    board.borrow_mut().set_cpu(cpu);
    let mut report = SimReport {
        target: target.description.clone(),
        ..Default::default()
    };
    out(Line::Result(format!("PDI side: {}", target.description)));

    let storage: Box<PduStorage<16, { PduStorage::element_size(1100) }>> =
        Box::new(PduStorage::new());
    let (tx, rx, pdu_loop) = storage
        .try_split()
        .map_err(|_| SimError("PDU storage already split".into()))?;
    let md = MainDevice::new(
        pdu_loop,
        crate::rig::master::in_process_timeouts(),
        MainDeviceConfig {
            dc_static_sync_iterations: 100,
            ..Default::default()
        },
    );
    let result = futures_lite::future::block_on(futures_lite::future::or(
        master(cfg, &md, &board, &mut report, out),
        tx_rx_task(board.clone(), tx, rx),
    ));
    let b = board.borrow();
    report.frames = b.stats.frames;
    report.virtual_ns = b.now_ns();
    report.dac_updates = b.dac().borrow().updates.clone();
    report.wall = wall.elapsed();
    if let (Some(path), Some(p)) = (&cfg.pcap, b.pcap()) {
        p.save(path)
            .map_err(|e| SimError(format!("cannot write {}: {e}", path.display())))?;
        report.pcap = Some((path.clone(), p.frames()));
        out(Line::Result(format!(
            "pcap: {} frames -> {}",
            p.frames(),
            path.display()
        )));
    }
    result.map(|()| report).map_err(|e| {
        let esc = b.esc().borrow();
        SimError(format!(
            "{e} (the board shows AL status {:#06x}, AL status code {:#06x})",
            esc.peek_u16(crate::models::esc::regs::AL_STATUS),
            esc.peek_u16(crate::models::esc::regs::AL_STATUS_CODE)
        ))
    })
}

async fn master(
    cfg: &SimConfig,
    md: &MainDevice<'_>,
    board: &Rc<RefCell<VirtualBoard>>,
    report: &mut SimReport,
    out: Out<'_>,
) -> Result<(), SimError> {
    let fail = |what: &str, e: ethercrab::error::Error| SimError(format!("{what}: {e}"));
    out(Line::Progress("master: scanning the segment".into()));
    let mut group = md
        .init_single_group::<2, 64>(ethercat_now)
        .await
        .map_err(|e| fail("INIT -> PRE-OP", e))?;
    report.states.push("INIT".into());
    out(Line::Result("ESM: INIT".into()));
    {
        let sd = group
            .subdevice(md, 0)
            .map_err(|e| fail("no slave found", e))?;
        out(Line::Result("ESM: INIT -> PRE-OP".into()));
        record_state(&sd, report, out).await;
        let id = sd.identity();
        report.name = sd.name().to_string();
        report.identity = (id.vendor_id, id.product_id, id.revision, id.serial);
        out(Line::Result(format!(
            "identity (SII): \"{}\" vendor {:#010x} product {:#010x} revision {:#010x} serial {:#010x}",
            report.name, id.vendor_id, id.product_id, id.revision, id.serial
        )));
        out(Line::Progress(
            "master: reading the object dictionary over SDO".into(),
        ));
        report.sdo = read_identity_sdos(&sd).await;
        for v in &report.sdo {
            out(Line::Result(format!(
                "SDO {:#06x}:{:02} {:<17} {}",
                v.index,
                v.sub,
                v.label,
                match &v.value {
                    Ok(s) => s.clone(),
                    Err(e) => format!("(not read: {e})"),
                }
            )));
        }
        report.od = read_od_summary(&sd).await;
        match &report.od {
            None => out(Line::Result(
                "object dictionary: the device has no CoE SDO Information".into(),
            )),
            Some(Ok(od)) => {
                out(Line::Result(format!(
                    "object dictionary: {} objects: {}",
                    od.all.len(),
                    hex_list(&od.all)
                )));
                out(Line::Result(format!(
                    "  RxPDO-mappable: {}; TxPDO-mappable: {}",
                    hex_list(&od.rx_mappable),
                    hex_list(&od.tx_mappable)
                )));
            }
            Some(Err(e)) => out(Line::Result(format!(
                "object dictionary: SDO Information failed: {e}"
            ))),
        }
        let pdo = read_pdo_layout(&sd).await;
        match &pdo {
            Ok(p) => out(Line::Result(format!(
                "PDO mapping: SM2 {} -> {} output bits, SM3 {} -> {} input bits",
                hex_list(&p.rx_pdos),
                p.outputs.iter().map(|e| e.bits as usize).sum::<usize>(),
                hex_list(&p.tx_pdos),
                p.inputs.iter().map(|e| e.bits as usize).sum::<usize>(),
            ))),
            Err(e) => out(Line::Result(format!("PDO mapping: not read ({e})"))),
        }
        report.pdo = Some(pdo);
    }
    for mut sd in group.iter_mut(md) {
        sd.set_dc_sync(DcSync::Sync0);
    }
    let cycle = Duration::from_nanos(cfg.cycle_ns());
    // ethercrab 0.7.1: `configure_dc_sync` accepts a PRE-OP group and returns it as
    // "PRE-OP with PDI" WITHOUT configuring SM2/SM3 and the FMMUs; configure them first.
    let group = group
        .into_pre_op_pdi(md)
        .await
        .map_err(|e| fail("PDI configuration", e))?;
    let group = group
        .configure_dc_sync(
            md,
            DcConfiguration {
                // ethercrab rounds the first pulse down to a whole cycle: a delay of one
                // cycle more keeps it after the activation's write.
                start_delay: Duration::from_millis(1) + cycle,
                sync0_period: cycle,
                // The master sends each frame half a cycle after a SYNC0 edge (below:
                // `next_cycle_wait`), so the outputs reach SM2 half a cycle before the edge
                // that latches them, whatever phase ethercrab's wall-clock DC start gave.
                sync0_shift: cycle / 2,
            },
        )
        .await
        .map_err(|e| fail("DC configuration", e))?;
    out(Line::Result(format!("DC: SYNC0 every {} us", cfg.cycle_us)));
    let group = group
        .into_safe_op(md)
        .await
        .map_err(|e| fail("PRE-OP -> SAFE-OP", e))?;
    out(Line::Result("ESM: PRE-OP -> SAFE-OP".into()));
    record_state(
        &group.subdevice(md, 0).map_err(|e| fail("slave", e))?,
        report,
        out,
    )
    .await;
    let group = group
        .into_op(md)
        .await
        .map_err(|e| fail("SAFE-OP -> OP", e))?;
    out(Line::Result("ESM: SAFE-OP -> OP".into()));
    record_state(
        &group.subdevice(md, 0).map_err(|e| fail("slave", e))?,
        report,
        out,
    )
    .await;

    // The loop-back: the master copies AI (0x6401:ai+1) to AO (0x6411:ao+1) each cycle.
    let io = match &report.pdo {
        Some(Ok(p)) => p
            .input(0x6401, cfg.ai_channel + 1)
            .zip(p.output(0x6411, cfg.ao_channel + 1)),
        _ => None,
    };
    let cycle_ns = cfg.cycle_ns();
    let n_cycles = (cfg.loopback_seconds() * 1e9 / cycle_ns as f64).ceil() as u64;
    let sync = |board: &Rc<RefCell<VirtualBoard>>, t: u64| {
        let mut b = board.borrow_mut();
        let now = b.now_ns();
        if t > now {
            b.step(t - now);
        }
    };
    match io {
        None => {
            out(Line::Result(format!(
                "loop-back: skipped (0x6401:{:02} or 0x6411:{:02} is not in the PDO mapping)",
                cfg.ai_channel + 1,
                cfg.ao_channel + 1
            )));
            for _ in 0..100 {
                let t0 = board.borrow().now_ns();
                let resp = group.tx_rx_dc(md).await.map_err(|e| fail("cycle", e))?;
                sync(board, t0 + resp.extra.next_cycle_wait.as_nanos() as u64);
                report.cycles += 1;
            }
        }
        Some((ai, ao)) => {
            out(Line::Result(format!(
                "loop-back: AI{} (0x6401:{:02}, input bit {}) -> master -> AO{} (0x6411:{:02}, output bit {}), \
                 sine {} V +- {} V, {} us cycle, {} s per frequency",
                cfg.ai_channel, cfg.ai_channel + 1, ai.bit_offset, cfg.ao_channel, cfg.ao_channel + 1,
                ao.bit_offset, cfg.offset_v, cfg.amplitude_v, cfg.cycle_us, cfg.loopback_seconds()
            )));
            for &freq in &cfg.freqs_hz {
                let signal = Signal::Sine {
                    amplitude: cfg.amplitude_v,
                    offset: cfg.offset_v,
                    freq_hz: freq,
                    phase: 0.0,
                };
                board.borrow().adc().borrow_mut().inputs[cfg.ai_channel as usize] = signal.clone();
                let t_start = board.borrow().now_ns();
                let mut next_progress = 0;
                for i in 0..n_cycles {
                    // The frame passes the ESC at this virtual time (its DC time stamp).
                    let t0 = board.borrow().now_ns();
                    let resp = group.tx_rx_dc(md).await.map_err(|e| fail("cycle", e))?;
                    if !resp.all_op() {
                        return Err(SimError(format!(
                            "the slave left OP during the loop-back (cycle {i})"
                        )));
                    }
                    {
                        let sd = group.subdevice(md, 0).map_err(|e| fail("slave", e))?;
                        let v = get_i16(&sd.inputs_raw(), ai.bit_offset).unwrap_or(0);
                        set_i16(&mut sd.outputs_raw_mut(), ao.bit_offset, v);
                    }
                    report.cycles += 1;
                    sync(board, t0 + resp.extra.next_cycle_wait.as_nanos() as u64);
                    let pct = (i + 1) * 100 / n_cycles;
                    if pct >= next_progress {
                        out(Line::Progress(format!(
                            "loop-back {freq} Hz: {pct:3}% ({} of {n_cycles} cycles, {:.3} s virtual)",
                            i + 1,
                            (i + 1) as f64 * cycle_ns as f64 * 1e-9
                        )));
                        next_progress = pct + 25;
                    }
                }
                let t_end = board.borrow().now_ns();
                // Leave out the first cycles (the pipeline fills with the old signal).
                let settle = 16 * cycle_ns;
                let updates = board.borrow().dac().borrow().updates.clone();
                let opts = AnalysisOptions {
                    latency_hint_ns: Some(3.0 * cycle_ns as f64),
                    ..Default::default()
                };
                let a = loopback::analyze_dac(
                    &signal,
                    &updates,
                    cfg.ao_channel,
                    freq,
                    t_start + settle,
                    t_end,
                    &opts,
                )
                .map_err(|e| e.to_string());
                match &a {
                    Ok(a) => out(Line::Result(format!("loop-back {a}"))),
                    Err(e) => out(Line::Result(format!("loop-back {freq} Hz: {e}"))),
                }
                report.loopback.push((freq, a));
            }
        }
    }
    let group = group
        .into_safe_op(md)
        .await
        .map_err(|e| fail("OP -> SAFE-OP", e))?;
    out(Line::Result("ESM: OP -> SAFE-OP".into()));
    let group = group
        .into_pre_op(md)
        .await
        .map_err(|e| fail("SAFE-OP -> PRE-OP", e))?;
    out(Line::Result("ESM: SAFE-OP -> PRE-OP".into()));
    group
        .into_init(md)
        .await
        .map_err(|e| fail("PRE-OP -> INIT", e))?;
    report.states.push("INIT".into());
    out(Line::Result("ESM: PRE-OP -> INIT".into()));
    Ok(())
}

/// What a wall-clock run served.
#[derive(Clone, Debug, Default)]
pub struct WallClockReport {
    /// EtherCAT side (frames answered on the interface, time served, AL status).
    pub ecat: ServeStats,
    /// CAN side, if served: connections and frames through socketcand, frames on the bus.
    pub can: Option<(crate::tools::socketcand::ServerStats, u64)>,
    /// Every load of a DAC register, in order (what the outputs the master wrote became).
    pub dac_updates: Vec<DacUpdate>,
}

/// Serves the board on the wall clock until Ctrl-C (or `cfg.seconds`): on the network
/// interface `cfg.iface` for an EtherCAT master and/or on the CAN bus through socketcand
/// on `cfg.can_port` for a CANopen master. Without `--iface` the EtherCAT port stays
/// unconnected (the module is a CANopen device only, its ESM in INIT).
pub fn run_wall_clock(
    cfg: &SimConfig,
    target: Target,
    stop: &AtomicBool,
    out: Out<'_>,
) -> Result<WallClockReport, SimError> {
    cfg.validate().map_err(|e| SimError(e.to_string()))?;
    let sock = match cfg.iface.as_deref() {
        Some(name) => Some(RawSocket::open(name).map_err(|e| SimError(e.to_string()))?),
        None => None,
    };
    let mut server = match cfg.can_port {
        Some(port) => Some(SocketcandServer::bind(port).map_err(|e| {
            SimError(format!(
                "--can-port {port}: cannot listen on 127.0.0.1:{port}: {e}"
            ))
        })?),
        None => None,
    };
    let description = target.description.clone();
    let mut board = target.into_board(|b| {
        b.capture = cfg.pcap.is_some();
        b.can_bit_rate = cfg.can_bit_rate;
    });
    board.adc().borrow_mut().inputs[cfg.ai_channel as usize] = Signal::Sine {
        amplitude: cfg.amplitude_v,
        offset: cfg.offset_v,
        freq_hz: cfg.freqs_hz[0],
        phase: 0.0,
    };
    for (ch, v) in cfg.ai_levels_v.iter().enumerate() {
        if let Some(v) = *v {
            board.adc().borrow_mut().inputs[ch] = Signal::Constant(v);
        }
    }
    let until = match cfg.seconds {
        Some(s) => format!(" for {s} s"),
        None => " until Ctrl-C".into(),
    };
    out(Line::Result(format!(
        "virtual board, PDI side: {}; AI{} = {} V +- {} V at {} Hz; serving{until}",
        description, cfg.ai_channel, cfg.offset_v, cfg.amplitude_v, cfg.freqs_hz[0],
    )));
    if let (Some(sock), Some(name)) = (&sock, cfg.iface.as_deref()) {
        let slowed = match cfg.slowdown {
            1 => String::new(),
            n => format!(
                "; the board's clock runs {n} times slower than the wall clock (give the \
                 master a cycle {n} times as long)"
            ),
        };
        out(Line::Result(format!(
            "EtherCAT: interface `{name}` (ifindex {}){slowed}, waiting for frames",
            sock.ifindex()
        )));
    }
    if let Some(server) = &server {
        out(Line::Result(format!(
            "CAN: {} kbit/s, node-ID {}; socketcand on 127.0.0.1:{} (bus `{BUS_NAME}`): \
             python-can `can.Bus(interface=\"socketcand\", host=\"127.0.0.1\", port={}, channel=\"{BUS_NAME}\")`",
            cfg.can_bit_rate / 1000,
            cfg.node_id,
            server.port(),
            server.port(),
        )));
    }
    let opts = ServeOptions {
        duration: cfg.seconds.map(Duration::from_secs_f64),
        slowdown: cfg.slowdown,
        ..Default::default()
    };
    let can_frames = |b: &VirtualBoard| b.can().borrow().stats.frames;
    let stats = iface::serve_ports(
        &mut board,
        sock.as_ref(),
        server.as_mut(),
        stop,
        &opts,
        &mut |s| {
            out(Line::Progress(format!(
                "{:6.1} s: {} EtherCAT frames answered, AL status {:#06x}, virtual time {:.2} ms \
                 behind",
                s.elapsed.as_secs_f64(),
                s.frames,
                s.al_status,
                s.lag.end_ns as f64 * 1e-6
            )))
        },
    )
    .map_err(|e| SimError(format!("serving: {e}")))?;
    let report = WallClockReport {
        ecat: stats.clone(),
        can: server
            .as_ref()
            .map(|s| (s.stats.clone(), can_frames(&board))),
        dac_updates: board.dac().borrow().updates.clone(),
    };
    out(Line::Result(format!(
        "served {:.1} s: {} EtherCAT frames ({} dropped), AL status {:#06x}; DAC outputs A {:.4} V, B {:.4} V",
        stats.elapsed.as_secs_f64(),
        stats.frames,
        stats.dropped,
        stats.al_status,
        board.dac().borrow().output_volts(0).unwrap_or(0.0),
        board.dac().borrow().output_volts(1).unwrap_or(0.0),
    )));
    out(Line::Result(serving_summary(&stats, sock.is_some())));
    if let Some((s, frames)) = &report.can {
        out(Line::Result(format!(
            "CAN: {frames} frames on the bus; socketcand: {} connections, {} frames in, {} out",
            s.connections, s.frames_in, s.frames_out
        )));
    }
    if let (Some(path), Some(p)) = (&cfg.pcap, board.pcap()) {
        p.save(path)
            .map_err(|e| SimError(format!("cannot write {}: {e}", path.display())))?;
        out(Line::Result(format!(
            "pcap: {} frames -> {}",
            p.frames(),
            path.display()
        )));
    }
    Ok(report)
}

/// The timing of a wall-clock run: the frames' answer latency and how far the CPU's
/// virtual time was behind the wall clock.
pub fn serving_summary(stats: &ServeStats, frames: bool) -> String {
    let mut s = String::new();
    if frames {
        s.push_str(&format!(
            "frame answer latency (arrival on the interface to the reply's send): {}; answered \
             at {}\n",
            stats.latency.summary("frames"),
            if stats.realtime {
                format!("real-time priority (SCHED_FIFO {})", iface::ANSWER_PRIORITY)
            } else {
                "normal priority (real-time needs root)".to_string()
            }
        ));
    }
    s.push_str(&format!(
        "virtual time behind the wall clock: {}",
        stats.lag.summary(stats.elapsed)
    ));
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_errors_are_clear() {
        let c = SimConfig::default();
        c.validate().unwrap();
        let bad = |f: &dyn Fn(&mut SimConfig)| {
            let mut c = SimConfig::default();
            f(&mut c);
            c.validate().unwrap_err().0
        };
        assert!(bad(&|c| c.cycle_us = 10).contains("at least 25 us"));
        assert!(bad(&|c| c.seconds = Some(0.0)).contains("positive"));
        assert!(bad(&|c| c.seconds = Some(f64::NAN)).contains("positive"));
        assert!(bad(&|c| c.freqs_hz = vec![]).contains("at least one"));
        assert!(bad(&|c| c.freqs_hz = vec![-1.0]).contains("positive"));
        assert!(bad(&|c| c.freqs_hz = vec![6000.0]).contains("half the cycle rate"));
        assert!(bad(&|c| c.seconds = Some(0.01)).contains("one period of 50 Hz"));
        assert!(bad(&|c| c.amplitude_v = 6.0).contains("0..10 V"));
        assert!(bad(&|c| c.ai_channel = 8).contains("0..=7"));
        assert!(bad(&|c| c.ao_channel = 2).contains("0..=1"));
        let e = bad(&|c| c.can_bit_rate = 800_000);
        assert!(
            e.contains("10000, 20000, 50000, 125000, 250000, 500000, 1000000 bit/s"),
            "{e}"
        );
        assert!(bad(&|c| c.node_id = 0).contains("1..=127"));
        assert!(bad(&|c| c.ai_levels_v[3] = Some(10.5)).contains("analog input 3"));
        assert!(bad(&|c| c.slowdown = 4).contains("for a master on --iface"));
        // On an interface --seconds is wall time and may be long, and the board may be
        // slowed down.
        let mut c = SimConfig {
            seconds: Some(3600.0),
            iface: Some("vb1".into()),
            slowdown: 16,
            ..Default::default()
        };
        c.validate().unwrap();
        c.slowdown = 0;
        assert!(c.validate().unwrap_err().0.contains("1 (real time)"));
        c.slowdown = 2;
        c.can_port = Some(29536);
        assert!(c.validate().unwrap_err().0.contains("not with --can-port"));
    }

    #[test]
    fn image_access() {
        let mut img = [0u8; 4];
        assert!(set_i16(&mut img, 16, -2));
        assert_eq!(img, [0, 0, 0xFE, 0xFF]);
        assert_eq!(get_i16(&img, 16), Some(-2));
        assert_eq!(get_i16(&img, 24), None);
        assert!(!set_i16(&mut img, 24, 1));
    }
}
