//! Both boards measured the same way, side by side: the LPC1754 with the ET1100 on SPI and
//! the STM32F103 with the ET1100 on the FSMC, each release image swept for the shortest DC
//! cycle it sustains ([`crate::bench::sweep`]: the same master script, the same ESC, DAC and
//! ADC models, the same "sustained" rule), with SYNC0 -> LDAC and the CPU load there.
//!
//! The STM32 figures rest on the ET1100's µC PDI timing, which no datasheet at hand gives
//! (`et1100::unconfirmed::ucontroller`, the model's `BusTiming::NO_CLASH`), and on
//! [`crate::stm32::unconfirmed`]'s time model.

use crate::bench::{sweep_program, Plan, Program};
use crate::cosim::Options;
use crate::image::Image;
use crate::run::{image_target, CosimHandle};
use std::fmt::Write as _;
use virtual_board::models::esc::parallel::BusTiming;
use virtual_board::tools::image_figures::Sweep;
use virtual_board::tools::sim::Target;

/// The release image with every ESC access clashing with a frame (the long end of the
/// UNCONFIRMED BUSY range, `BusTiming::FRAME_CLASH`).
fn frame_clash_target(image: Image, options: Options) -> Result<(Target, CosimHandle), String> {
    image_target(
        image,
        Options {
            esc_bus_timing: Some(BusTiming::FRAME_CLASH),
            ..options
        },
    )
}

/// One board's figures.
pub struct BoardFigures {
    /// The board, for the table.
    pub board: String,
    /// The product whose image ran.
    pub product: String,
    /// The CPU clock (Hz).
    pub cclk_hz: u64,
    /// The sweep.
    pub sweep: Sweep,
}

/// Sweeps `image` (of `product` on `board`) as `cargo xtask bench` does (`quick`: its short
/// form); `frame_clash`: with the ESC's longest BUSY on every access (the FSMC board).
pub fn measure(
    board: &str,
    product: &str,
    image: &Image,
    quick: bool,
    frame_clash: bool,
    progress: &mut dyn FnMut(&str),
) -> BoardFigures {
    let plan = Plan::new(quick);
    let mut program = Program::release(image);
    if frame_clash {
        program.target = frame_clash_target;
    }
    // Both boards under the traffic the advertised minimum is judged with (SDO exchanges in
    // OP, frame jitter, moving inputs).
    let traffic = crate::traffic::Traffic::REAL_MASTER;
    let sweep = sweep_program(&program, &plan, None, &traffic, &mut |c| {
        progress(&format!(
            "{board}: cycle {:.1} us: {} (CPU load {:.1} %)",
            c.cycle_ns as f64 / 1e3,
            c.verdict(),
            100.0 * c.cpu_load
        ))
    });
    BoardFigures {
        board: board.into(),
        product: product.into(),
        cclk_hz: image.chip.clock_hz(),
        sweep,
    }
}

/// The boards as a Markdown table: shortest sustained DC cycle, SYNC0 -> LDAC (mean, max)
/// and CPU load at that cycle.
pub fn table(boards: &[BoardFigures]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| board | product | CPU | shortest sustained DC cycle | SYNC0 -> LDAC mean / max | \
         CPU load there |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|");
    for b in boards {
        let (cycle, latency, load) = match b.sweep.shortest_sustained() {
            Some(c) => (
                format!(
                    "{:.0} us (next shorter tried: {})",
                    c.cycle_ns as f64 / 1e3,
                    b.sweep.first_failing().map_or("none".into(), |f| format!(
                        "{:.0} us, {}",
                        f.cycle_ns as f64 / 1e3,
                        f.verdict()
                    ))
                ),
                format!(
                    "{:.2} / {:.2} us",
                    c.sync0_to_ldac.mean_ns / 1e3,
                    c.sync0_to_ldac.max_ns as f64 / 1e3
                ),
                format!("{:.1} %", 100.0 * c.cpu_load),
            ),
            None => (
                format!(
                    "none sustained ({})",
                    b.sweep
                        .points
                        .first()
                        .map_or("no cycle tried".into(), |p| p.verdict())
                ),
                "-".into(),
                "-".into(),
            ),
        };
        let _ = writeln!(
            s,
            "| {} | {} | {} MHz | {cycle} | {latency} | {load} |",
            b.board,
            b.product,
            b.cclk_hz / 1_000_000
        );
    }
    let _ = writeln!(
        s,
        "\nSweep: {}. The STM32 rows rest on UNCONFIRMED ET1100 µC PDI timing (BUSY 80 ns per \
         access without a competing frame, 260 ns with one on every access) and on the \
         co-simulator's CPI 5/4 for both cores.",
        boards
            .first()
            .map_or(String::new(), |b| b.sweep.method.clone())
    );
    s
}
