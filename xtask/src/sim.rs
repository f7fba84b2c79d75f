//! `cargo xtask sim`: the virtual board (a software ET1100 + AD5663 + AD7689 running the
//! firmware's slave application) driven by a real EtherCAT master.
//!
//! In process (the default), ethercrab walks the ESM, reads the identity and the object
//! dictionary over SDO, then repeats the thesis loop-back experiment: a sine into an
//! analog input, the master copies it to an analog output every cycle, and the DAC's
//! output is measured (amplitude, error, latency, THD). With `--iface NAME` the board
//! answers EtherCAT frames on a network interface instead, for any external master.

use crate::util::Result;
use std::path::PathBuf;
use virtual_board::tools::sim::{self, Line, SimConfig, Target};

#[derive(clap::Args, Debug)]
#[command(after_long_help = AFTER_HELP)]
pub struct Args {
    /// Process-data and DC SYNC0 cycle time in microseconds (25 ..= 4000000).
    #[arg(long, value_name = "N", default_value_t = sim::DEFAULT_CYCLE_US)]
    pub cycle_us: u32,
    /// In process: virtual seconds of loop-back per frequency (default 0.1, at most 60).
    /// With --iface: how long to serve, in wall-clock seconds (default: until Ctrl-C).
    #[arg(long, value_name = "S")]
    pub seconds: Option<f64>,
    /// Frequencies of the input sine in Hz, one run each (repeat the option or give
    /// several values). With --iface only the first is used.
    #[arg(long = "freq", value_name = "HZ", num_args = 1.., default_values_t = sim::DEFAULT_FREQS_HZ)]
    pub freqs: Vec<f64>,
    /// Amplitude of the input sine in volts (peak; 4 V = 8 V peak-to-peak).
    #[arg(long, value_name = "V", default_value_t = sim::DEFAULT_AMPLITUDE_V)]
    pub amplitude: f64,
    /// Offset of the input sine in volts (the inputs span 0..10 V).
    #[arg(long, value_name = "V", default_value_t = sim::DEFAULT_OFFSET_V)]
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
}

const AFTER_HELP: &str = "\
The board's virtual time: in process it advances with the frames and the cycle (a run is
fast and repeatable; --seconds is virtual time); on an interface it follows the wall clock.

Loop-back figures (per frequency): amplitude and offset of the DAC output's fundamental,
amplitude error against the input, latency (phase delay of the fundamental, including the
DAC's hold), THD over harmonics 2..10 and THD+N, all over whole periods of the output as
the DAC model recorded it.

Examples:
  cargo xtask sim
  cargo xtask sim --cycle-us 50 --freq 1000 --seconds 0.05 --pcap sim.pcap
  sudo ip link add vb0 type veth peer name vb1 && sudo ip link set vb0 up && sudo ip link set vb1 up
  sudo cargo xtask sim --iface vb1          # then point a master at vb0 (README)";

impl Args {
    fn config(&self) -> SimConfig {
        SimConfig {
            cycle_us: self.cycle_us,
            seconds: self.seconds,
            freqs_hz: self.freqs.clone(),
            amplitude_v: self.amplitude,
            offset_v: self.offset,
            ai_channel: self.ai,
            ao_channel: self.ao,
            pcap: self.pcap.clone(),
            iface: self.iface.clone(),
        }
    }
}

fn print(line: Line) {
    match line {
        Line::Result(s) => println!("{s}"),
        Line::Progress(s) => eprintln!("[sim] {s}"),
    }
}

pub fn run(args: &Args) -> Result {
    let cfg = args.config();
    cfg.validate().map_err(|e| e.to_string())?;
    if let Some(name) = &cfg.iface {
        // Check the interface before anything else, for a clear message.
        virtual_board::tools::iface::RawSocket::open(name).map_err(|e| e.to_string())?;
    }
    let target = if args.echo {
        Target::echo()
    } else {
        match sim::firmware_target() {
            Ok(t) => t,
            Err(why) => {
                println!("{why}");
                println!("(`cargo xtask sim --echo` runs the transport test responder instead)");
                return Ok(());
            }
        }
    };
    if cfg.iface.is_some() {
        let stop = virtual_board::tools::iface::ctrl_c_flag();
        sim::run_on_interface(&cfg, target, stop, &mut print).map_err(|e| e.to_string())?;
        if let Some(path) = &cfg.pcap {
            check_pcap(path)?;
        }
        return Ok(());
    }
    let report = sim::run_in_process(&cfg, target, &mut print).map_err(|e| e.to_string())?;
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
    match sim::tshark::summarize(path) {
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
