//! The command line of `cargo xtask sim` (and of the image co-simulator's `sim`, which
//! takes the same options): the virtual board driven by a real EtherCAT master.
//!
//! In process (the default), ethercrab walks the ESM, reads the identity and the object
//! dictionary over SDO, then repeats the thesis loop-back experiment: a sine into an
//! analog input, the master copies it to an analog output every cycle, and the DAC's
//! output is measured (amplitude, error, latency, THD). With `--iface NAME` the board
//! answers EtherCAT frames on a network interface instead, for any external master.

use super::{Line, SimConfig, SimReport, Target};
use std::path::PathBuf;

type Result<T = ()> = std::result::Result<T, String>;

#[derive(clap::Args, Debug)]
#[command(after_long_help = AFTER_HELP)]
pub struct SimArgs {
    /// Process-data and DC SYNC0 cycle time in microseconds (25 ..= 4000000).
    #[arg(long, value_name = "N", default_value_t = super::DEFAULT_CYCLE_US)]
    pub cycle_us: u32,
    /// In process: virtual seconds of loop-back per frequency (default 0.1, at most 60).
    /// With --iface or --can-port: how long to serve, in wall-clock seconds (default: until
    /// Ctrl-C).
    #[arg(long, value_name = "S")]
    pub seconds: Option<f64>,
    /// Frequencies of the input sine in Hz, one run each (repeat the option or give
    /// several values). With --iface only the first is used.
    #[arg(long = "freq", value_name = "HZ", num_args = 1.., default_values_t = super::DEFAULT_FREQS_HZ)]
    pub freqs: Vec<f64>,
    /// Amplitude of the input sine in volts (peak; 4 V = 8 V peak-to-peak).
    #[arg(long, value_name = "V", default_value_t = super::DEFAULT_AMPLITUDE_V)]
    pub amplitude: f64,
    /// Offset of the input sine in volts (the inputs span 0..10 V).
    #[arg(long, value_name = "V", default_value_t = super::DEFAULT_OFFSET_V)]
    pub offset: f64,
    /// Analog input that gets the sine: 0..=7 (0x6401:01..08).
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub ai: u8,
    /// Analog output the master copies it to: 0..=1 (0x6411:01..02).
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub ao: u8,
    /// Write every frame (both directions) to this pcap file (Wireshark/tshark).
    #[arg(long, value_name = "FILE")]
    pub pcap: Option<PathBuf>,
    /// Attach the board to this Linux network interface (raw socket, needs root) and answer
    /// the frames of an external master, instead of running the in-process master.
    #[arg(long, value_name = "NAME")]
    pub iface: Option<String>,
    /// Run the transport test responder (test SII, no CoE, output word echoed to the
    /// inputs) instead of the firmware: for checking a master's link only.
    #[arg(long)]
    pub echo: bool,
    /// Serve the module's CAN bus through socketcand on 127.0.0.1:PORT (wall-clock time,
    /// until Ctrl-C or --seconds; together with --iface both fieldbuses are served):
    /// python-can's `socketcand` interface, channel `can0`, connects to it.
    #[arg(long, value_name = "PORT")]
    pub can_port: Option<u16>,
    /// CAN bit rate in bit/s (10000, 20000, 50000, 125000, 250000, 500000 or 1000000: the
    /// module's, as its EDS lists them).
    #[arg(long, value_name = "BPS", default_value_t = crate::rig::board::DEFAULT_CAN_BIT_RATE)]
    pub can_bit_rate: u32,
    /// The module's CANopen node-ID (1..=127).
    #[arg(long, value_name = "N", default_value_t = super::DEFAULT_NODE_ID)]
    pub node_id: u8,
    /// With --iface: the board's clock runs N times slower than the wall clock (DC time,
    /// SYNC0, the watchdogs, the CPU): for a co-simulated image too slow for real time, such
    /// as the image serving the 250 kSPS oversampling stream. Give the master an N times
    /// longer cycle (it then sees the module as at full speed) and timeouts that allow it.
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub slowdown: u32,
    /// The 1 kHz loop-back with oversampling, on the image only (with `--image`): N output
    /// updates per cycle (a multiple of 5, the update PDOs carry 5 each), every conversion
    /// in (the sample PDOs the cycle needs), the master resampling AI1 onto AO1's update
    /// grid; --cycle-us and --seconds apply (docs/book/oversampling-loopback.md).
    #[arg(long, value_name = "N")]
    pub oversampling: Option<u16>,
    /// The product the board runs (`analog-io`, the default, or `analog-io-can`, which
    /// --can-port needs).
    #[arg(long, value_name = "NAME", default_value = firmware::products::default().name)]
    pub product: String,
}

impl SimArgs {
    /// The product `--product` names, or why there is none.
    pub fn product(&self) -> Result<&'static firmware::products::Product> {
        let product = firmware::products::find(&self.product).ok_or_else(|| {
            format!(
                "no product {:?}: the products are {}",
                self.product,
                firmware::products::NAMES.join(", ")
            )
        })?;
        if self.can_port.is_some() && product.can.is_none() && !self.echo {
            return Err(format!(
                "{} has no CANopen node: --can-port needs --product analog-io-can",
                product.name
            ));
        }
        Ok(product)
    }
}

/// The examples and notes under `--help`.
pub const AFTER_HELP: &str = "\
The board's virtual time: in process it advances with the frames and the cycle (a run is
fast and repeatable; --seconds is virtual time); on an interface or with --can-port it
follows the wall clock.

Loop-back figures (per frequency): amplitude and offset of the DAC output's fundamental,
amplitude error against the input, latency (phase delay of the fundamental, including the
DAC's hold), THD over harmonics 2..10 and THD+N, all over whole periods of the output as
the DAC model recorded it.

Examples:
  cargo xtask sim
  cargo xtask sim --cycle-us 1000 --freq 100 --seconds 0.05 --pcap sim.pcap
  cargo xtask sim --image --cycle-us 1000 --oversampling 20   # the loop-back with oversampling
  sudo ip link add vb0 type veth peer name vb1 && sudo ip link set vb0 up && sudo ip link set vb1 up
  sudo cargo xtask sim --iface vb1          # then point a master at vb0 (docs/book/getting-started-virtual.md)
  cargo xtask sim --product analog-io-can --can-port 29536   # then python-canopen (docs/book/canopen.md)";

impl SimArgs {
    /// The run's configuration.
    pub fn config(&self) -> SimConfig {
        SimConfig {
            cycle_us: self.cycle_us,
            seconds: self.seconds,
            freqs_hz: self.freqs.clone(),
            amplitude_v: self.amplitude,
            offset_v: self.offset,
            ai_channel: self.ai,
            ao_channel: self.ao,
            ai_levels_v: [None; 8],
            pcap: self.pcap.clone(),
            iface: self.iface.clone(),
            can_port: self.can_port,
            can_bit_rate: self.can_bit_rate,
            node_id: self.node_id,
            slowdown: self.slowdown,
        }
    }
}

/// Prints a line: results to stdout, progress to stderr.
pub fn print(line: Line) {
    match line {
        Line::Result(s) => println!("{s}"),
        Line::Progress(s) => eprintln!("[sim] {s}"),
    }
}

/// Runs the board with the target `make_target` gives (called after the options are
/// checked): in process, or on the wall clock (`--iface`, `--can-port`). `after` prints what the caller adds (the image
/// co-simulator's facts) before the verdict.
pub fn run(
    args: &SimArgs,
    make_target: impl FnOnce(bool) -> Result<Option<Target>>,
    after: &mut dyn FnMut(),
) -> Result {
    let cfg = args.config();
    cfg.validate().map_err(|e| e.to_string())?;
    if let Some(name) = &cfg.iface {
        // Check the interface before anything else, for a clear message.
        crate::tools::iface::RawSocket::open(name).map_err(|e| e.to_string())?;
    }
    let Some(target) = make_target(args.echo)? else {
        return Ok(());
    };
    if cfg.wall_clock() {
        let stop = crate::tools::iface::ctrl_c_flag();
        let served = super::run_wall_clock(&cfg, target, stop, &mut print);
        after();
        served.map_err(|e| e.to_string())?;
        if let Some(path) = &cfg.pcap {
            check_pcap(path)?;
        }
        return Ok(());
    }
    let report = super::run_in_process(&cfg, target, &mut print);
    after();
    let report: SimReport = report.map_err(|e| e.to_string())?;
    if let Some((path, _)) = &report.pcap {
        check_pcap(path)?;
    }
    println!(
        "done: {} cycles, {} frames, {:.3} s virtual in {:.2} s wall",
        report.cycles,
        report.frames,
        report.virtual_ns as f64 * 1e-9,
        report.wall.as_secs_f64()
    );
    let failed: Vec<String> = report
        .loopback
        .iter()
        .filter_map(|(f, r)| r.as_ref().err().map(|e| format!("{f} Hz: {e}")))
        .collect();
    if !failed.is_empty() {
        return Err(format!("loop-back failed: {}", failed.join("; ")));
    }
    Ok(())
}

/// The independent check of a capture: tshark must decode every frame, none malformed.
fn check_pcap(path: &std::path::Path) -> Result {
    match super::tshark::summarize(path) {
        None => println!("tshark not installed: the capture was not cross-checked"),
        Some(Err(e)) => return Err(e),
        Some(Ok(s)) => {
            println!(
                "tshark: {} frames, {} decoded as EtherCAT, {} malformed",
                s.frames, s.ecat, s.malformed
            );
            if s.malformed != 0 || s.ecat != s.frames {
                return Err(format!("tshark does not accept {}", path.display()));
            }
        }
    }
    Ok(())
}
