//! CYCLE IDENTITY OF THE MODELS: fixed, deterministic runs of the release images whose exact
//! figures (CPU cycles, instructions, crossings to the board's chips, and the ordered trace of
//! DAC loads and LDAC edges) are pinned, together with a fingerprint of the image they were
//! taken on. They were first recorded on commit 6c355aa, before the co-simulator's chips were
//! split into their own modules (issue 30), and held through the split.
//!
//! - Same image fingerprint, other figures: the simulated timing changed. A deliberate model
//!   change re-records them and says why in its commit; a refactor must leave them as they
//!   are.
//! - Other fingerprint: the firmware (or its build) changed, and its figures with it. Record
//!   the new ones (the failure prints them) in a commit that changes no model, so the next
//!   model change is judged against them.
//!
//! Everything here runs on the board's virtual time (the master's DC clock is the board's,
//! its jitter a fixed sequence), so two runs of one image give the same figures.

use firmware::products::analog_io::sync::MIN_CYCLE_TIME_NS;
use lpc1754_cosim::bench::{dc_run_traffic, DcRun, Program};
use lpc1754_cosim::cosim::Facts;
use lpc1754_cosim::image::Image;
use lpc1754_cosim::oversampling::{self, Config};
use lpc1754_cosim::run::{load_image, load_image_of};
use lpc1754_cosim::traffic::Traffic;

/// FNV-1a over 64-bit words: a hash that stays the same across Rust releases (std's
/// `DefaultHasher` does not promise that).
#[derive(Clone, Copy)]
struct Fnv(u64);

impl Fnv {
    fn new() -> Self {
        Fnv(0xCBF2_9CE4_8422_2325)
    }

    fn word(mut self, w: u64) -> Self {
        for b in w.to_le_bytes() {
            self.0 = (self.0 ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01B3);
        }
        self
    }
}

/// What a run must reproduce exactly.
#[derive(Debug, PartialEq, Eq)]
struct Figures {
    /// [`Fnv`] over the image's flash contents: which firmware the figures are of.
    image: u64,
    cycles: u64,
    instructions: u64,
    sleep_cycles: u64,
    time_ns: u64,
    esc_bytes: u64,
    fsmc_cycles: u64,
    dac_frames: u64,
    ldac_pulses: u64,
    adc_conversions: u64,
    sync0_captures: u64,
    /// AD7689 results the CPU read from the GPDMA ring (the LPC1754's; 0 on the STM32).
    samples_read: u64,
    /// [`Fnv`] over the DAC register loads (time, channel, code) and then the LDAC edges
    /// (time, direction), each in order.
    dac_trace: u64,
}

/// [`Fnv`] over the flash an image fills, in 8-byte words.
fn fingerprint(image: &Image) -> u64 {
    image.flash[..image.flash_used]
        .chunks(8)
        .fold(Fnv::new(), |h, w| {
            let mut b = [0u8; 8];
            b[..w.len()].copy_from_slice(w);
            h.word(u64::from_le_bytes(b))
        })
        .0
}

fn figures(image: &Image, f: &Facts, dac_trace: u64) -> Figures {
    Figures {
        image: fingerprint(image),
        cycles: f.cycles,
        instructions: f.instructions,
        sleep_cycles: f.sleep_cycles,
        time_ns: f.time_ns,
        esc_bytes: f.traffic.esc_bytes,
        fsmc_cycles: f.fsmc_cycles,
        dac_frames: f.traffic.dac_frames,
        ldac_pulses: f.traffic.ldac_pulses,
        adc_conversions: f.traffic.adc_conversions,
        sync0_captures: f.traffic.sync0_captures,
        samples_read: f.samples.read,
        dac_trace,
    }
}

fn dc_trace(run: &DcRun) -> u64 {
    let h = run.dac_updates.iter().fold(Fnv::new(), |h, u| {
        h.word(u.time_ns)
            .word(u64::from(u.channel))
            .word(u64::from(u.code))
    });
    run.ldac_edges
        .iter()
        .fold(h, |h, e| h.word(e.time_ns).word(u64::from(e.falling)))
        .0
}

/// Boot, mailbox traffic in PRE-OP, DC SYNC0 at the advertised minimum cycle, then 300
/// judged cycles in OP under a real master's traffic (SDO exchanges, frame jitter, moving
/// inputs): every path of the image's cycle, and the mailbox beside it.
fn dc_figures(product: &str) -> (Figures, DcRun) {
    let image = load_image_of(product).expect("the product's release image");
    let run = dc_run_traffic(
        &Program::release(&image),
        u64::from(MIN_CYCLE_TIME_NS),
        300,
        true,
        None,
        &Traffic::REAL_MASTER,
    )
    .expect("the run");
    assert!(run.check.failure.is_none(), "{:?}", run.check.failure);
    let trace = dc_trace(&run);
    (figures(&image, &run.after, trace), run)
}

#[test]
fn the_lpc1754_image_runs_cycle_identically() {
    let (got, run) = dc_figures(firmware::products::default().name);
    assert_eq!(run.check.edges, 300);
    assert_eq!(
        got,
        Figures {
            image: 5_132_822_816_997_794_988,
            cycles: 10_689_562,
            instructions: 4_511_005,
            sleep_cycles: 5_016_343,
            time_ns: 108_102_226,
            esc_bytes: 27_837,
            fsmc_cycles: 0,
            dac_frames: 649,
            ldac_pulses: 322,
            adc_conversions: 24_415,
            sync0_captures: 326,
            samples_read: 24_376,
            dac_trace: 1_416_020_112_222_759_298,
        }
    );
}

#[test]
fn the_stm32_image_runs_cycle_identically() {
    let (got, run) = dc_figures("analog-io-stm32");
    assert_eq!(run.check.edges, 300);
    assert_eq!(
        got,
        Figures {
            image: 10_519_340_094_008_427_980,
            cycles: 6_918_107,
            instructions: 2_078_626,
            sleep_cycles: 4_161_879,
            time_ns: 98_680_468,
            esc_bytes: 0,
            fsmc_cycles: 13_738,
            dac_frames: 647,
            ldac_pulses: 322,
            adc_conversions: 19_120,
            sync0_captures: 323,
            samples_read: 0,
            dac_trace: 2_423_205_288_595_415_684,
        }
    );
}

/// The oversampling path of the LPC1754 image (GPDMA ring, PWM1 on LDAC): 50 cycles at 1 ms
/// with 8 sample PDOs and 20 output updates per cycle; the input blocks' contents are pinned
/// too.
#[test]
fn the_lpc1754_oversampling_image_runs_cycle_identically() {
    let image = load_image().expect("the release image");
    let config = Config {
        cycle_ns: 1_000_000,
        cycles: 50,
        sample_pdos: 8,
        sine_hz: 1_234.5,
        update_pdos: 4,
    };
    let r = oversampling::run(&image, config).expect("the run");
    let trace = r
        .dac_a
        .iter()
        .fold(Fnv::new(), |h, &(t, code)| h.word(t).word(u64::from(code)));
    let trace = r.ldac_falls.iter().fold(trace, |h, &t| h.word(t)).0;
    let blocks = r
        .blocks
        .iter()
        .fold(Fnv::new(), |h, b| {
            let h = h
                .word(u64::from(b.counter))
                .word(u64::from(b.scans))
                .word(u64::from(b.status))
                .word(b.time_dc);
            b.samples.iter().fold(h, |h, &s| h.word(u64::from(s)))
        })
        .0;
    assert_eq!(
        (figures(&image, &r.after, trace), r.blocks.len(), blocks),
        (
            Figures {
                image: 5_132_822_816_997_794_988,
                cycles: 15_574_324,
                instructions: 8_535_978,
                sleep_cycles: 4_852_339,
                time_ns: 156_949_846,
                esc_bytes: 76_025,
                fsmc_cycles: 0,
                dac_frames: 2_725,
                ldac_pulses: 1_379,
                adc_conversions: 36_627,
                sync0_captures: 71,
                samples_read: 36_552,
                dac_trace: 2_446_500_947_638_559_095,
            },
            50,
            8_724_289_964_679_047_468
        )
    );
}
