//! Input oversampling on the image (docs/book/oversampling.md): ethercrab assigns the block
//! PDOs (0x1A10, 0x1A11, 0x1A20..) over SDO in PRE-OP, runs DC SYNC0 at a cycle, and keeps
//! every block; the analysis checks the stream (scan counter continuous, nothing lost or
//! repeated, status clean) and rebuilds a sine fed to AI1 from the samples and their DC
//! times. Shared by the system test and `cargo xtask bench`.

pub mod loopback;

use crate::bench::{
    al_status, assign_pdos, master, refused, step_to, sync0_started, Board, Storage,
};
use crate::cosim::{Facts, Options};
use crate::image::Image;
use crate::run::image_target;
use ethercrab::subdevice_group::DcConfiguration;
use ethercrab::{DcSync, PduStorage};
use std::cell::RefCell;
use std::f64::consts::PI;
use std::rc::Rc;
use std::time::Duration;
use virtual_board::models::adc::Signal;
use virtual_board::models::esc::SyncSignal;
use virtual_board::rig::master::tx_rx_task;

/// Channels of a scan.
pub const CHANNELS: usize = 8;
/// Conversion period (ns).
pub const PERIOD_NS: u64 = 4_000;
/// Block PDOs: status, time, then the sample PDOs.
const STATUS_PDO: u16 = 0x1A10;
const TIME_PDO: u16 = 0x1A11;
const SAMPLE_PDO: u16 = 0x1A20;
/// The first output update PDO (5 updates of AO1, AO2 each).
const UPDATE_PDO: u16 = 0x1620;
/// Updates per update PDO.
pub const UPDATES_PER_PDO: usize = 5;
/// Cycles in OP before the blocks count (the stream starts at SAFE-OP; the first blocks
/// in OP are kept from the warm-up on).
const WARM_UP_CYCLES: u64 = 20;

/// The sine on AI1 (V at the connector): 4 V around 5 V.
pub const SINE_AMPLITUDE_V: f64 = 4.0;
/// Its offset.
pub const SINE_OFFSET_V: f64 = 5.0;
/// Its phase at DC time 0.
pub const SINE_PHASE: f64 = 0.3;
/// The constant inputs of AI2..AI8.
pub const OTHER_INPUTS_V: [f64; 7] = [1.0, 2.0, 3.0, 4.0, 6.0, 8.0, 9.5];

/// What the master assigns.
#[derive(Debug, Clone, Copy)]
pub struct Config {
    /// DC cycle (ns).
    pub cycle_ns: u64,
    /// Cycles in OP that count.
    pub cycles: u64,
    /// Sample PDOs (32 slots each).
    pub sample_pdos: u8,
    /// Frequency of the sine on AI1 (Hz).
    pub sine_hz: f64,
    /// Output update PDOs assigned in 0x1C12 (5 updates each; 0: today's 0x1600).
    pub update_pdos: u8,
}

impl Config {
    /// n, the output updates per cycle.
    pub fn updates(&self) -> usize {
        usize::from(self.update_pdos) * UPDATES_PER_PDO
    }
}

/// The pair the master writes for update `k` of the block of cycle `i` (both channels
/// change at every update; A climbs by [`UPDATE_STEP`] from update to update).
pub fn update_pair(i: u64, n: usize, k: usize) -> (u16, u16) {
    let a = ((i * n as u64 + k as u64) * u64::from(UPDATE_STEP)) as u16;
    (a, !a)
}

/// How much channel A's code climbs per update in [`update_pair`].
pub const UPDATE_STEP: u16 = 97;

/// One block as the master received it.
#[derive(Debug, Clone, Default)]
pub struct Block {
    /// Scan counter of its first scan.
    pub counter: u32,
    /// Whole scans.
    pub scans: u8,
    /// Status bits.
    pub status: u8,
    /// DC time of its first conversion.
    pub time_dc: u64,
    /// The valid samples (scans x 8).
    pub samples: Vec<u16>,
}

/// A run: the blocks and the image's facts around it.
#[derive(Debug)]
pub struct OsRun {
    /// The configuration.
    pub config: Config,
    /// The blocks of the counted cycles, in order.
    pub blocks: Vec<Block>,
    /// Input image bytes per cycle.
    pub input_bytes: usize,
    /// Virtual time of the counted cycles (ns).
    pub span_ns: u64,
    /// The ESC's DC system time minus the board's virtual time (ns): the ADC model's
    /// inputs are functions of virtual time.
    pub dc_minus_virtual_ns: i64,
    /// Virtual time of a SYNC0 edge (the grid's origin).
    pub sync0_origin_ns: u64,
    /// Virtual time where the counted cycles start.
    pub start_ns: u64,
    /// LDAC falling edges in the counted cycles (virtual ns).
    pub ldac_falls: Vec<u64>,
    /// Channel A's DAC register loads in the counted cycles (virtual ns, code).
    pub dac_a: Vec<(u64, u16)>,
    /// The slave's 0x1C33:06 (calc and copy time of the inputs) with the run's assignment,
    /// read in PRE-OP (ns).
    pub input_calc_copy_ns: u32,
    /// For each SYNC0 edge of the counted cycles, the time to the last byte of the next
    /// input image the PDI completed in SM3 (ns): what 0x1C33:06 must cover.
    pub sync0_to_inputs_ns: Vec<u64>,
    /// Facts at the start of the counted cycles and at the end.
    pub before: Facts,
    /// At the end.
    pub after: Facts,
}

/// The stream's verdict.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StreamCheck {
    /// Conversions delivered.
    pub samples: u64,
    /// Conversions the counter says were skipped (lost).
    pub lost: u64,
    /// Conversions delivered twice (a block overlapping the one before).
    pub duplicated: u64,
    /// Blocks with a status bit set.
    pub flagged_blocks: u64,
    /// Smallest and largest scans per block.
    pub scans_range: (u8, u8),
    /// Samples per second delivered (all channels).
    pub samples_per_s: f64,
    /// Block time against scan counter x scan length + t0: largest deviation (ns).
    pub time_jitter_ns: u64,
}

/// The sine rebuilt from AI1's samples.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SineFit {
    /// Amplitude (V).
    pub amplitude_v: f64,
    /// Its error against the input's, relative.
    pub amplitude_error: f64,
    /// The phase error as a time (ns): the sample times against the input's.
    pub time_error_ns: f64,
    /// RMS residual (V).
    pub residual_rms_v: f64,
}

/// What the master writes into the update PDOs (0x1620..) each cycle in OP, and what it
/// learns from the input blocks.
pub trait OutputMaster {
    /// An input block as received, in order from the first cycle in OP on (a block read
    /// twice comes twice).
    fn received(&mut self, block: &Block);
    /// Fills the update part of the output image for the frame of cycle `i` (n pairs of
    /// AO1, AO2 codes, little endian). `plays_from_dc`: the DC time of the SYNC0 edge the
    /// block plays from (the first edge after the frame), once the master knows the DC
    /// time (from the second frame in OP on).
    fn fill(&mut self, i: u64, plays_from_dc: Option<u64>, out: &mut [u8]);
    /// Whether the frame of cycle `i` goes out at all (a master that misses a cycle).
    fn sends(&self, i: u64) -> bool {
        let _ = i;
        true
    }
}

/// The test pattern: [`update_pair`] for every update, whatever came in.
#[derive(Debug, Clone, Default)]
pub struct ClimbingCodes {
    /// Cycles whose frame the master leaves out.
    pub skipped: Vec<u64>,
}

impl OutputMaster for ClimbingCodes {
    fn received(&mut self, _: &Block) {}
    fn sends(&self, i: u64) -> bool {
        !self.skipped.contains(&i)
    }
    fn fill(&mut self, i: u64, _: Option<u64>, out: &mut [u8]) {
        let n = out.len() / 4;
        for (k, b) in out.chunks_exact_mut(4).enumerate() {
            let (a, bb) = update_pair(i, n, k);
            b[..2].copy_from_slice(&a.to_le_bytes());
            b[2..].copy_from_slice(&bb.to_le_bytes());
        }
    }
}

/// Runs the image with the block PDOs at `config`; the outputs (if any) climb by
/// [`UPDATE_STEP`] per update.
pub fn run(image: &Image, config: Config) -> Result<OsRun, String> {
    run_with(image, config, &mut ClimbingCodes::default())
}

/// [`run`] with the outputs `outputs` writes.
pub fn run_with(
    image: &Image,
    config: Config,
    outputs: &mut dyn OutputMaster,
) -> Result<OsRun, String> {
    let (target, handle) = image_target(image.clone(), Options::default())?;
    let board: Board = Rc::new(RefCell::new(target.into_board(|cfg| cfg.capture = false)));
    {
        let adc = board.borrow().adc().clone();
        let mut adc = adc.borrow_mut();
        adc.inputs[0] = Signal::Sine {
            amplitude: SINE_AMPLITUDE_V,
            offset: SINE_OFFSET_V,
            freq_hz: config.sine_hz,
            phase: SINE_PHASE,
        };
        for (i, v) in OTHER_INPUTS_V.iter().enumerate() {
            adc.inputs[i + 1] = Signal::Constant(*v);
        }
    }
    let facts = || {
        handle
            .with(|c| c.facts())
            .ok_or_else(|| "the co-simulator did not start".to_string())
    };
    let storage: Box<Storage> = Box::new(PduStorage::new());
    let (md, tx, rx) = master(&storage)?;
    let mut blocks = Vec::new();
    let mut input_bytes = 0;
    let mut before = None;
    let mut start = 0;
    let mut sync0_origin = 0;
    let mut sync0_origin_dc = 0;
    let mut input_calc_copy_ns = 0;
    board.borrow().esc().borrow_mut().record_pdi_buffer_writes = true;
    step_to(&board, 2_000_000);
    let cycle_ns = config.cycle_ns;
    let master = async {
        let clock = board.borrow().clock().clone();
        let group = md
            .init_single_group::<2, 1024>(|| clock.now_ns())
            .await
            .map_err(|e| format!("INIT -> PRE-OP: {e}"))?;
        let mut pdos = vec![STATUS_PDO, TIME_PDO];
        pdos.extend((0..u16::from(config.sample_pdos)).map(|b| SAMPLE_PDO + b));
        {
            let sd = group.subdevice(&md, 0).map_err(|e| e.to_string())?;
            assign_pdos(&sd, 0x1C13, &pdos).await?;
            input_calc_copy_ns = sd
                .sdo_read::<u32>(0x1C33, 6)
                .await
                .map_err(|e| format!("0x1C33:06: {e}"))?;
            if config.update_pdos > 0 {
                let rx: Vec<u16> = (0..u16::from(config.update_pdos))
                    .map(|u| UPDATE_PDO + u)
                    .collect();
                assign_pdos(&sd, 0x1C12, &rx).await?;
            }
        }
        let mut group = group;
        for mut sd in group.iter_mut(&md) {
            sd.set_dc_sync(DcSync::Sync0);
        }
        let group = group
            .into_pre_op_pdi(&md)
            .await
            .map_err(|e| format!("process data: {e}"))?;
        let group = group
            .configure_dc_sync(
                &md,
                DcConfiguration {
                    // ethercrab rounds the start down to a whole cycle: a delay of
                    // several cycles keeps it in the future.
                    start_delay: Duration::from_nanos(10_000_000.max(4 * cycle_ns)),
                    sync0_period: Duration::from_nanos(cycle_ns),
                    sync0_shift: Duration::from_nanos(cycle_ns / 2),
                },
            )
            .await
            .map_err(|e| format!("DC: {e}"))?;
        let group = group
            .into_safe_op(&md)
            .await
            .map_err(|e| refused(&board, "PRE-OP -> SAFE-OP", e))?;
        sync0_started(&board);
        (sync0_origin, sync0_origin_dc) = next_sync0(&board);
        let group = group
            .into_op(&md)
            .await
            .map_err(|e| refused(&board, "SAFE-OP -> OP", e))?;
        let mut last_dc: Option<u64> = None;
        for i in 0..WARM_UP_CYCLES + config.cycles {
            if i == WARM_UP_CYCLES {
                before = Some(facts()?);
                start = board.borrow().now_ns();
            }
            let t0 = board.borrow().now_ns();
            if !outputs.sends(i) {
                // No frame: the board runs the cycle alone.
                last_dc = last_dc.map(|dc| dc + cycle_ns);
                step_to(&board, t0 + cycle_ns);
                continue;
            }
            if config.update_pdos > 0 {
                let sd = group.subdevice(&md, 0).map_err(|e| e.to_string())?;
                let mut out = sd.outputs_raw_mut();
                let n = config.updates();
                // This frame passes the ESC about a cycle after the last one; its block
                // plays from the first SYNC0 edge after that.
                let plays_from_dc = last_dc.map(|dc| {
                    let frame = dc + cycle_ns;
                    let past_edge = (frame + cycle_ns - sync0_origin_dc % cycle_ns) % cycle_ns;
                    frame - past_edge + cycle_ns
                });
                let part = out
                    .get_mut(..4 * n)
                    .ok_or_else(|| format!("output image of {} bytes", 4 * n))?;
                outputs.fill(i, plays_from_dc, part);
            }
            let resp = group
                .tx_rx_dc(&md)
                .await
                .map_err(|e| format!("cycle {i}: {e}"))?;
            if !resp.all_op() {
                let (status, code) = al_status(&board);
                return Err(format!(
                    "the slave left OP at cycle {i} (AL status {status:#06x}, code {code:#06x})"
                ));
            }
            last_dc = Some(resp.extra.dc_system_time);
            let block = {
                let sd = group.subdevice(&md, 0).map_err(|e| e.to_string())?;
                let img = sd.inputs_raw();
                input_bytes = img.len();
                parse_block(&img)?
            };
            outputs.received(&block);
            if i >= WARM_UP_CYCLES {
                blocks.push(block);
            }
            // The frames half a cycle after the SYNC0 edges (shift T/2): the PDI task has
            // written the edge's input block by then, and an output block is in before the
            // last update interval of the cycle. (Frames right at the edges raced with the
            // block's write: each block was read twice or not at all, depending on a few
            // instructions.)
            let phase = resp.extra.dc_system_time % cycle_ns;
            step_to(&board, t0 + (cycle_ns - phase));
        }
        Ok::<(), String>(())
    };
    let result = futures_lite::future::block_on(futures_lite::future::or(
        master,
        tx_rx_task(board.clone(), tx, rx),
    ));
    let after = facts()?;
    if let Err(e) = result {
        return Err(format!("{e}\n{}", after.summary()));
    }
    if let Some(f) = &after.fault {
        return Err(format!("the image faulted: {f}"));
    }
    let end = board.borrow().now_ns();
    let span_ns = end - start;
    let (ldac_falls, dac_a) = {
        let b = board.borrow();
        let dac = b.dac().borrow();
        let falls = dac
            .ldac_edges
            .iter()
            .filter(|e| e.falling && (start..end).contains(&e.time_ns))
            .map(|e| e.time_ns)
            .collect();
        let a = dac
            .updates
            .iter()
            .filter(|u| u.channel == 0 && (start..end).contains(&u.time_ns))
            .map(|u| (u.time_ns, u.code))
            .collect();
        (falls, a)
    };
    let sync0_to_inputs_ns = {
        let b = board.borrow();
        let esc = b.esc().borrow();
        let inputs: Vec<u64> = esc
            .pdi_buffer_writes
            .iter()
            .filter(|w| w.0 == 3)
            .map(|w| w.1)
            .collect();
        let edges: Vec<u64> = b
            .sync_edges
            .iter()
            .filter(|e| e.signal == SyncSignal::Sync0 && (start..end).contains(&e.time_ns))
            .map(|e| e.time_ns)
            .collect();
        edges
            .windows(2)
            .filter_map(|w| {
                let i = inputs.partition_point(|&t| t < w[0]);
                inputs.get(i).filter(|&&t| t < w[1]).map(|t| t - w[0])
            })
            .collect()
    };
    let dc_minus_virtual_ns = {
        let b = board.borrow();
        let sys = b.esc().borrow().dc_system_time();
        sys as i64 - b.now_ns() as i64
    };
    Ok(OsRun {
        config,
        blocks,
        input_bytes,
        span_ns,
        dc_minus_virtual_ns,
        sync0_origin_ns: sync0_origin,
        start_ns: start,
        ldac_falls,
        dac_a,
        input_calc_copy_ns,
        sync0_to_inputs_ns,
        before: before.ok_or("no counted cycle")?,
        after,
    })
}

/// The DC unit's next SYNC0 pulse (0x0990, which the master wrote): its virtual time and
/// its DC time.
fn next_sync0(board: &Board) -> (u64, u64) {
    let b = board.borrow();
    let esc = b.esc().borrow();
    let mut t = [0u8; 8];
    esc.peek(virtual_board::models::esc::regs::DC_START_TIME, &mut t);
    let next = u64::from_le_bytes(t);
    (b.now_ns() + next.saturating_sub(esc.dc_system_time()), next)
}

/// The output blocks' verdict.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct OutputCheck {
    /// LDAC falling edges per second.
    pub updates_per_s: f64,
    /// Largest distance of an LDAC fall from the grid SYNC0 + k T/n (ns).
    pub edge_error_max_ns: u64,
    /// Channel A loads that did not climb by one step from the load before (an update
    /// played twice, skipped or out of order).
    pub sequence_breaks: u64,
    /// Channel A loads.
    pub loads: u64,
}

/// The output updates of `run`: every LDAC edge on the grid, every update played once and
/// in order.
pub fn check_outputs(run: &OsRun) -> OutputCheck {
    let n = run.config.updates().max(1) as u64;
    let period = run.config.cycle_ns / n;
    let edge_error_max_ns = run
        .ldac_falls
        .iter()
        .map(|t| {
            let d = (*t as i128 - run.sync0_origin_ns as i128).rem_euclid(period as i128);
            d.min(period as i128 - d) as u64
        })
        .max()
        .unwrap_or(u64::MAX);
    let sequence_breaks = run
        .dac_a
        .windows(2)
        .filter(|w| w[1].1 != w[0].1.wrapping_add(UPDATE_STEP))
        .count() as u64;
    OutputCheck {
        updates_per_s: run.ldac_falls.len() as f64 / (run.span_ns as f64 * 1e-9),
        edge_error_max_ns,
        sequence_breaks,
        loads: run.dac_a.len() as u64,
    }
}

/// A block from the input image (status, time, samples).
fn parse_block(img: &[u8]) -> Result<Block, String> {
    if img.len() < 14 {
        return Err(format!("input image of {} bytes", img.len()));
    }
    let scans = img[4];
    let valid = usize::from(scans) * CHANNELS;
    let slots = (img.len() - 14) / 2;
    if valid > slots {
        return Err(format!("{scans} scans in {slots} slots"));
    }
    Ok(Block {
        counter: u32::from_le_bytes([img[0], img[1], img[2], img[3]]),
        scans,
        status: img[5],
        time_dc: u64::from_le_bytes(img[6..14].try_into().map_err(|_| "time")?),
        samples: img[14..14 + 2 * valid]
            .chunks_exact(2)
            .map(|b| u16::from_le_bytes([b[0], b[1]]))
            .collect(),
    })
}

/// The stream's verdict over the blocks of `run`.
pub fn check_stream(run: &OsRun) -> StreamCheck {
    let mut c = StreamCheck {
        scans_range: (u8::MAX, 0),
        ..Default::default()
    };
    let scan_ns = PERIOD_NS * CHANNELS as u64;
    let mut expected: Option<u32> = None;
    // Each block's time from the first's, by the counter's distance (it wraps).
    let first = run.blocks.first().map(|b| (b.time_dc, b.counter));
    for b in &run.blocks {
        c.samples += b.samples.len() as u64;
        if let Some(e) = expected {
            let d = i64::from(b.counter.wrapping_sub(e) as i32) * CHANNELS as i64;
            if d > 0 {
                c.lost += d as u64;
            } else {
                c.duplicated += (-d) as u64;
            }
        }
        expected = Some(b.counter.wrapping_add(u32::from(b.scans)));
        c.flagged_blocks += u64::from(b.status != 0);
        c.scans_range = (c.scans_range.0.min(b.scans), c.scans_range.1.max(b.scans));
        if let Some((t0, c0)) = first {
            let want = t0.wrapping_add(u64::from(b.counter.wrapping_sub(c0)) * scan_ns);
            c.time_jitter_ns = c.time_jitter_ns.max(b.time_dc.abs_diff(want));
        }
    }
    c.samples_per_s = c.samples as f64 * 1e9 / run.span_ns.max(1) as f64;
    c
}

/// AI1's samples with their times (s; the board's virtual time, from the DC times the
/// blocks give) and volts.
pub fn ai1_samples(run: &OsRun) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    for b in &run.blocks {
        let first = b.time_dc as i64 - run.dc_minus_virtual_ns;
        for (i, code) in b.samples.iter().step_by(CHANNELS).enumerate() {
            let t = first as f64 + (i * CHANNELS) as f64 * PERIOD_NS as f64;
            out.push((t * 1e-9, f64::from(*code) / 65536.0 * 10.0));
        }
    }
    out
}

/// Least-squares fit of `offset + a sin(w t) + b cos(w t)` at the input's frequency: the
/// amplitude and the phase against the input's (as a time).
pub fn fit_sine(points: &[(f64, f64)], freq_hz: f64) -> SineFit {
    let w = 2.0 * PI * freq_hz;
    // Normal equations of the three unknowns.
    let mut m = [[0.0f64; 3]; 3];
    let mut v = [0.0f64; 3];
    for (t, y) in points {
        let row = [(w * t).sin(), (w * t).cos(), 1.0];
        for ((mi, vi), ri) in m.iter_mut().zip(v.iter_mut()).zip(row) {
            for (mij, rj) in mi.iter_mut().zip(row) {
                *mij += ri * rj;
            }
            *vi += ri * y;
        }
    }
    let x = solve3(m, v);
    let amplitude = x[0].hypot(x[1]);
    // a sin + b cos = A sin(w t + phi), phi = atan2(b, a).
    let phase = x[1].atan2(x[0]);
    let mut dphi = phase - SINE_PHASE;
    while dphi > PI {
        dphi -= 2.0 * PI;
    }
    while dphi < -PI {
        dphi += 2.0 * PI;
    }
    let residual = points
        .iter()
        .map(|(t, y)| y - (x[0] * (w * t).sin() + x[1] * (w * t).cos() + x[2]))
        .map(|r| r * r)
        .sum::<f64>();
    SineFit {
        amplitude_v: amplitude,
        amplitude_error: (amplitude - SINE_AMPLITUDE_V).abs() / SINE_AMPLITUDE_V,
        // A sample time late by d reads the input at t + d: the phase leads by w d.
        time_error_ns: dphi / w * 1e9,
        residual_rms_v: (residual / points.len().max(1) as f64).sqrt(),
    }
}

fn solve3(mut m: [[f64; 3]; 3], mut v: [f64; 3]) -> [f64; 3] {
    for col in 0..3 {
        let pivot = (col..3)
            .max_by(|a, b| m[*a][col].abs().total_cmp(&m[*b][col].abs()))
            .unwrap_or(col);
        m.swap(col, pivot);
        v.swap(col, pivot);
        let (pivot_row, pivot_v) = (m[col], v[col]);
        for (row, (mr, vr)) in m.iter_mut().zip(v.iter_mut()).enumerate() {
            if row != col && pivot_row[col] != 0.0 {
                let f = mr[col] / pivot_row[col];
                for (x, p) in mr.iter_mut().zip(pivot_row) {
                    *x -= f * p;
                }
                *vr -= f * pivot_v;
            }
        }
    }
    [0, 1, 2].map(|i| if m[i][i] != 0.0 { v[i] / m[i][i] } else { 0.0 })
}

/// The configurations `cargo xtask bench` measures (cycle, sample PDOs, update PDOs): the
/// fewest sample PDOs that hold a cycle's scans at 1 ms, 500 us and the advertised minimum
/// (270 us), alone and with output blocks: 20 kHz per channel at 1 ms and 500 us, and the
/// largest factor 1 ms admits beside the inputs (25 updates, 25 kHz).
pub const BENCH_CONFIGS: [(u64, u8, u8); 6] = [
    (1_000_000, 8, 0),
    (1_000_000, 8, 4),
    (1_000_000, 8, 5),
    (500_000, 4, 0),
    (500_000, 4, 2),
    (MIN_CYCLE_NS, 3, 0),
];

/// The advertised minimum cycle (0x1C32:05), the shortest the module accepts.
const MIN_CYCLE_NS: u64 = firmware::products::analog_io::sync::MIN_CYCLE_TIME_NS as u64;

/// One line of figures of a run: samples per second (total and per channel), lost and
/// duplicated, flagged blocks, PDI input bytes per cycle against the valid payload, CPU
/// load over the counted cycles.
pub fn figures(run: &OsRun) -> String {
    figures_of(run, true)
}

/// [`figures`] of a run whose outputs are not the climbing test pattern (the loop-back):
/// without the sequence check.
pub fn figures_without_sequence(run: &OsRun) -> String {
    figures_of(run, false)
}

fn figures_of(run: &OsRun, climbing: bool) -> String {
    let c = check_stream(run);
    let cycles = run.blocks.len().max(1) as f64;
    let payload = c.samples as f64 * 2.0 / cycles;
    let busy = |f: &Facts| f.cycles.saturating_sub(f.sleep_cycles);
    let all = run.after.cycles.saturating_sub(run.before.cycles).max(1);
    let load = busy(&run.after).saturating_sub(busy(&run.before)) as f64 / all as f64;
    let outputs = if run.config.update_pdos > 0 {
        let o = check_outputs(run);
        let n = run.config.updates();
        let sequence = if climbing {
            format!(
                "{} sequence breaks in {} updates, ",
                o.sequence_breaks, o.loads
            )
        } else {
            String::new()
        };
        format!(
            ", {n} updates/cycle: {:.0} DAC updates/s per channel, LDAC edges within {} ns \
             of the DC grid, {sequence}output image {} B/cycle (read twice: {} B of PDI)",
            o.updates_per_s,
            o.edge_error_max_ns,
            4 * n,
            8 * n
        )
    } else {
        String::new()
    };
    format!(
        "cycle {:>5} us, {} sample PDOs: {:>7.0} samples/s ({:.0} per channel), lost {}, \
         duplicated {}, blocks flagged {}, scans/block {}..{}, input image {} B/cycle \
         ({:.0} B of samples), CPU load {:.1} %{outputs}",
        run.config.cycle_ns / 1_000,
        run.config.sample_pdos,
        c.samples_per_s,
        c.samples_per_s / CHANNELS as f64,
        c.lost,
        c.duplicated,
        c.flagged_blocks,
        c.scans_range.0,
        c.scans_range.1,
        run.input_bytes,
        payload,
        100.0 * load
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fit_finds_amplitude_and_a_time_shift() {
        let f = 1_234.5;
        let shift = 1.5e-6;
        let points: Vec<(f64, f64)> = (0..20_000)
            .map(|i| {
                let t = 0.01 + i as f64 * 32e-6;
                let y = SINE_OFFSET_V
                    + SINE_AMPLITUDE_V * (2.0 * PI * f * (t + shift) + SINE_PHASE).sin();
                (t, y)
            })
            .collect();
        let fit = fit_sine(&points, f);
        assert!(fit.amplitude_error < 1e-9, "{fit:?}");
        assert!((fit.time_error_ns - 1_500.0).abs() < 1.0, "{fit:?}");
    }

    fn run_of(blocks: Vec<Block>) -> OsRun {
        OsRun {
            config: Config {
                cycle_ns: 1_000_000,
                cycles: 0,
                sample_pdos: 8,
                sine_hz: 1.0,
                update_pdos: 0,
            },
            blocks,
            input_bytes: 0,
            span_ns: 1_000_000,
            dc_minus_virtual_ns: 0,
            sync0_origin_ns: 0,
            start_ns: 0,
            ldac_falls: Vec::new(),
            dac_a: Vec::new(),
            input_calc_copy_ns: 0,
            sync0_to_inputs_ns: Vec::new(),
            before: Facts::default(),
            after: Facts::default(),
        }
    }

    fn block(counter: u32, scans: u8) -> Block {
        Block {
            counter,
            scans,
            status: 0,
            time_dc: 1_000 + u64::from(counter) * 32_000,
            samples: vec![0; usize::from(scans) * CHANNELS],
        }
    }

    #[test]
    fn the_stream_check_counts_gaps_and_overlaps() {
        let c = check_stream(&run_of(vec![block(0, 31), block(31, 32), block(63, 31)]));
        assert_eq!((c.lost, c.duplicated, c.samples), (0, 0, 94 * 8));
        assert_eq!(c.scans_range, (31, 32));
        let c = check_stream(&run_of(vec![block(0, 31), block(33, 32), block(60, 31)]));
        assert_eq!((c.lost, c.duplicated), (2 * 8, 5 * 8));
    }
}
