//! The bench's figures as PNG files (`cargo xtask bench --plot DIR`), which the book embeds:
//!
//! - `loopback.png`: the thesis loop-back, one panel per frequency with the input sine and
//!   the DAC output over the last periods, the figures of the run in each panel's caption
//!   (and `loopback-oversampling.png`, the same drawing of the loop-back with oversampling
//!   on the image, one panel per cycle: `bench::oversampling`);
//! - `cycle-sweep.png`: the release image's DC cycle-time sweep on the co-simulator, CPU load
//!   and the longest SYNC0 -> LDAC latency per cycle time, sustained or not;
//! - `ldac-latency.png`: the histogram of the SYNC0 edge -> LDAC edge latency;
//! - `cpu-per-task.png`: the CPU share of each RTIC task.
//!
//! Text is drawn with DejaVu Sans from the `dejavu` crate through plotters' `ab_glyph` font
//! backend, so nothing depends on the fonts a machine has installed.

use crate::util::Result;
use plotters::coord::ranged1d::SegmentValue;
use plotters::prelude::*;
use plotters::style::{register_font, FontStyle};
use std::path::Path;
use std::sync::OnceLock;

/// One loop-back panel: time in ms from the start of the shown window, volts.
#[derive(Debug, Clone, PartialEq)]
pub struct Trace {
    /// Input frequency (Hz).
    pub freq_hz: f64,
    /// Input (sampled).
    pub input: Vec<(f64, f64)>,
    /// DAC output (as steps: two points per load).
    pub output: Vec<(f64, f64)>,
    /// The figures of this frequency (amplitude error, THD, latency), for the caption.
    pub figures: String,
}

/// One cycle time of the image's sweep.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SweepPoint {
    /// DC cycle (us).
    pub cycle_us: f64,
    /// CPU load over the judged cycles (0..1).
    pub cpu_load: f64,
    /// Longest SYNC0 edge -> LDAC edge (us).
    pub ldac_max_us: f64,
    /// No missed SYNC0, no stale output, no lost sample, still in OP.
    pub sustained: bool,
}

/// One figure of a sweep point.
type Measure = fn(&SweepPoint) -> f64;

/// The font family every figure's text uses.
const FAMILY: &str = "sans-serif";
/// Figure width in pixels.
const WIDTH: u32 = 1000;
/// Height of one loop-back panel.
const PANEL_HEIGHT: u32 = 300;
const INPUT: RGBColor = RGBColor(31, 119, 180);
const OUTPUT: RGBColor = RGBColor(214, 39, 40);
const GOOD: RGBColor = RGBColor(44, 160, 44);
const GRID: RGBColor = RGBColor(215, 215, 215);

/// Registers DejaVu Sans under [`FAMILY`] once. Text stays at 15 px or more: below that,
/// plotters' ab_glyph backend rounds small glyphs such as '.' a pixel or two off the baseline.
fn fonts() -> Result {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = REGISTERED.get_or_init(|| {
        register_font(FAMILY, FontStyle::Normal, dejavu::sans::regular()).is_ok()
            && register_font(FAMILY, FontStyle::Bold, dejavu::sans::bold()).is_ok()
    });
    if *ok {
        Ok(())
    } else {
        Err("the DejaVu fonts of the dejavu crate did not load".into())
    }
}

fn text(size: u32) -> TextStyle<'static> {
    (FAMILY, size).into_font().into()
}

fn bold(size: u32) -> TextStyle<'static> {
    (FAMILY, size, FontStyle::Bold).into_font().into()
}

/// A drawing error as a message naming the file.
fn fail(path: &Path) -> impl Fn(&dyn std::fmt::Display) -> String + '_ {
    move |e| format!("plot {}: {e}", path.display())
}

/// The loop-back figure: one panel per frequency, top to bottom in the order run.
pub fn loopback(path: &Path, title: &str, traces: &[Trace]) -> Result {
    if traces.is_empty() {
        return Err("nothing to plot".into());
    }
    fonts()?;
    let err = fail(path);
    let height = 50 + PANEL_HEIGHT * traces.len() as u32;
    let root = BitMapBackend::new(path, (WIDTH, height)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let root = root.titled(title, bold(20)).map_err(|e| err(&e))?;
    for (area, t) in root.split_evenly((traces.len(), 1)).iter().zip(traces) {
        let span = t
            .input
            .iter()
            .chain(&t.output)
            .map(|p| p.0)
            .fold(0.0f64, f64::max)
            .max(1e-6);
        let mut chart = ChartBuilder::on(area)
            .caption(format!("{} Hz: {}", t.freq_hz, t.figures), text(17))
            .margin_left(10)
            .margin_right(20)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..span, 0.0..12.5)
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .light_line_style(TRANSPARENT)
            .bold_line_style(GRID)
            .y_labels(6)
            .y_label_formatter(&|v| format!("{v:.1}"))
            .x_desc("time (ms)")
            .y_desc("voltage (V)")
            .label_style(text(16))
            .axis_desc_style(text(16))
            .draw()
            .map_err(|e| err(&e))?;
        chart
            .draw_series(LineSeries::new(
                t.input.iter().copied(),
                INPUT.stroke_width(2),
            ))
            .map_err(|e| err(&e))?
            .label("input (AI1)")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], INPUT.stroke_width(2)));
        chart
            .draw_series(LineSeries::new(
                t.output.iter().copied(),
                OUTPUT.stroke_width(2),
            ))
            .map_err(|e| err(&e))?
            .label("DAC output (AO1)")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], OUTPUT.stroke_width(2)));
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(text(15))
            .draw()
            .map_err(|e| err(&e))?;
    }
    root.present().map_err(|e| err(&e))
}

/// The cycle-time sweep: CPU load (top) and the longest SYNC0 -> LDAC latency (bottom) per
/// DC cycle, green where the image sustained the cycle, red where it did not; dashed lines
/// at the shortest sustained cycle and at the advertised minimum.
pub fn cycle_sweep(
    path: &Path,
    points: &[SweepPoint],
    shortest_us: Option<f64>,
    advertised_us: f64,
) -> Result {
    if points.is_empty() {
        return Err("no cycle time to plot".into());
    }
    fonts()?;
    let err = fail(path);
    let root = BitMapBackend::new(path, (WIDTH, 700)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let root = root
        .titled(
            "The release image on the co-simulated LPC1754: DC cycle time sweep (2 AO + 8 AI)",
            bold(20),
        )
        .map_err(|e| err(&e))?;
    let lo = points.iter().map(|p| p.cycle_us).fold(f64::MAX, f64::min);
    let hi = points
        .iter()
        .map(|p| p.cycle_us)
        .fold(advertised_us, f64::max);
    let x = (lo - 5.0).max(0.0)..(hi + 5.0);
    let latency_top = points.iter().map(|p| p.ldac_max_us).fold(1.0f64, f64::max) * 1.15;
    let panels = root.split_evenly((2, 1));
    let rows: [(&str, f64, Measure); 2] = [
        ("CPU load (%)", 100.0, |p| 100.0 * p.cpu_load),
        ("longest SYNC0 -> LDAC (us)", latency_top, |p| p.ldac_max_us),
    ];
    for (area, (what, top, value)) in panels.iter().zip(rows) {
        let mut chart = ChartBuilder::on(area)
            .margin_left(10)
            .margin_right(20)
            .margin_top(10)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(x.clone(), 0.0..top)
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .light_line_style(TRANSPARENT)
            .bold_line_style(GRID)
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| format!("{v:.0}"))
            .x_desc("DC cycle time (us)")
            .y_desc(what)
            .label_style(text(16))
            .axis_desc_style(text(16))
            .draw()
            .map_err(|e| err(&e))?;
        let mut marks: Vec<(f64, &str, RGBColor)> = vec![(advertised_us, "advertised", BLACK)];
        if let Some(s) = shortest_us {
            marks.push((s, "shortest sustained", GOOD));
        }
        for (at, label, color) in marks {
            chart
                .draw_series(DashedLineSeries::new(
                    [(at, 0.0), (at, top)],
                    6,
                    4,
                    color.stroke_width(1),
                ))
                .map_err(|e| err(&e))?
                .label(format!("{label}: {at:.0} us"))
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], color));
        }
        let sustained = points.iter().filter(|p| p.sustained);
        chart
            .draw_series(sustained.map(|p| Circle::new((p.cycle_us, value(p)), 5, GOOD.filled())))
            .map_err(|e| err(&e))?
            .label("sustained")
            .legend(|(x, y)| Circle::new((x + 10, y), 5, GOOD.filled()));
        let failed = points.iter().filter(|p| !p.sustained);
        chart
            .draw_series(
                failed.map(|p| Cross::new((p.cycle_us, value(p)), 6, OUTPUT.stroke_width(2))),
            )
            .map_err(|e| err(&e))?
            .label("not sustained (stale output, missed SYNC0 or left OP)")
            .legend(|(x, y)| Cross::new((x + 10, y), 6, OUTPUT.stroke_width(2)));
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(text(15))
            .draw()
            .map_err(|e| err(&e))?;
    }
    root.present().map_err(|e| err(&e))
}

/// The histogram of the SYNC0 edge -> LDAC edge latency: `histogram` is (ns, edges), one bar
/// per value (the latencies are whole CPU cycles of `cycle_ns`).
pub fn latency_histogram(
    path: &Path,
    title: &str,
    histogram: &[(u64, u64)],
    cycle_ns: f64,
) -> Result {
    let Some(&(first, _)) = histogram.first() else {
        return Err("no latency to plot".into());
    };
    fonts()?;
    let err = fail(path);
    let last = histogram.last().map_or(first, |h| h.0);
    let edges: u64 = histogram.iter().map(|h| h.1).sum();
    let most = histogram.iter().map(|h| h.1).max().unwrap_or(1);
    let pad = 4.0 * cycle_ns / 1e3;
    let x = (first as f64 / 1e3 - pad).max(0.0)..(last as f64 / 1e3 + pad);
    let root = BitMapBackend::new(path, (WIDTH, 450)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, bold(19))
        .margin_left(10)
        .margin_right(20)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(x, 0.0..(most as f64 * 1.1))
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .light_line_style(TRANSPARENT)
        .bold_line_style(GRID)
        .y_label_formatter(&|v| format!("{v:.0}"))
        .x_label_formatter(&|v| format!("{v:.2}"))
        .x_desc("SYNC0 edge -> LDAC edge (us)")
        .y_desc(format!("SYNC0 edges (of {edges})"))
        .label_style(text(16))
        .axis_desc_style(text(16))
        .draw()
        .map_err(|e| err(&e))?;
    let half = 0.4 * cycle_ns / 1e3;
    chart
        .draw_series(histogram.iter().map(|&(ns, n)| {
            let at = ns as f64 / 1e3;
            Rectangle::new([(at - half, 0.0), (at + half, n as f64)], INPUT.filled())
        }))
        .map_err(|e| err(&e))?;
    root.present().map_err(|e| err(&e))
}

/// The CPU share of each task (label, share 0..1), as horizontal bars, the largest on top.
pub fn cpu_per_task(path: &Path, title: &str, tasks: &[(String, f64)]) -> Result {
    if tasks.is_empty() {
        return Err("no task to plot".into());
    }
    let mut tasks = tasks.to_vec();
    tasks.sort_by(|a, b| a.1.total_cmp(&b.1));
    let tasks = &tasks[..];
    fonts()?;
    let err = fail(path);
    let n = tasks.len() as i32;
    let top = tasks.iter().map(|t| 100.0 * t.1).fold(10.0f64, f64::max) * 1.15;
    let root = BitMapBackend::new(path, (WIDTH, 120 + 50 * tasks.len() as u32)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, bold(19))
        .margin_left(10)
        .margin_right(30)
        .x_label_area_size(40)
        .y_label_area_size(230)
        .build_cartesian_2d(0.0..top, (0..n - 1).into_segmented())
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .light_line_style(TRANSPARENT)
        .bold_line_style(GRID)
        .disable_y_mesh()
        .y_labels(tasks.len())
        .y_label_formatter(&|v| match v {
            SegmentValue::CenterOf(i) => usize::try_from(*i)
                .ok()
                .and_then(|i| tasks.get(i))
                .map_or(String::new(), |t| t.0.clone()),
            _ => String::new(),
        })
        .x_label_formatter(&|v| format!("{v:.0}"))
        .x_desc("share of the CPU (%)")
        .label_style(text(16))
        .axis_desc_style(text(16))
        .draw()
        .map_err(|e| err(&e))?;
    chart
        .draw_series(tasks.iter().zip(0..).map(|((_, share), i)| {
            let mut bar = Rectangle::new(
                [
                    (0.0, SegmentValue::Exact(i)),
                    (100.0 * share, SegmentValue::Exact(i + 1)),
                ],
                INPUT.filled(),
            );
            bar.set_margin(8, 8, 0, 0);
            bar
        }))
        .map_err(|e| err(&e))?;
    chart
        .draw_series(tasks.iter().zip(0..).map(|((_, share), i)| {
            Text::new(
                format!("{:.1} %", 100.0 * share),
                (100.0 * share + top * 0.01, SegmentValue::CenterOf(i)),
                text(15),
            )
        }))
        .map_err(|e| err(&e))?;
    root.present().map_err(|e| err(&e))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Width and height from a PNG's IHDR.
    fn png_size(path: &Path) -> (u32, u32) {
        let png = std::fs::read(path).unwrap();
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
        (
            u32::from_be_bytes(png[16..20].try_into().unwrap()),
            u32::from_be_bytes(png[20..24].try_into().unwrap()),
        )
    }

    fn dir(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("xtask-plot-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn loopback_has_one_panel_per_trace() {
        let dir = dir("loopback");
        let path = dir.join("p.png");
        let sine: Vec<(f64, f64)> = (0..100)
            .map(|i| (i as f64 * 0.2, 5.0 + 4.0 * (i as f64 * 0.2 * 0.314).sin()))
            .collect();
        let t = Trace {
            freq_hz: 50.0,
            input: sine.clone(),
            output: sine,
            figures: "amplitude error -0.01 %".into(),
        };
        loopback(&path, "title", &[t.clone(), t]).unwrap();
        assert_eq!(png_size(&path), (WIDTH, 50 + 2 * PANEL_HEIGHT));
        assert!(loopback(&path, "title", &[]).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Text is drawn: a figure with a long caption has more dark pixels than without it
    /// (the font came from the dejavu crate, not the machine).
    #[test]
    fn text_is_drawn_with_the_embedded_font() {
        let dir = dir("text");
        let tasks = |label: &str| vec![(label.to_string(), 0.5)];
        let (a, b) = (dir.join("a.png"), dir.join("b.png"));
        cpu_per_task(&a, "", &tasks("")).unwrap();
        cpu_per_task(&b, "CPU per task: a long title", &tasks("pdi: EINT3")).unwrap();
        let size = |p: &Path| std::fs::metadata(p).unwrap().len();
        assert!(size(&b) > size(&a), "{} vs {}", size(&b), size(&a));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn sweep_histogram_and_tasks_write_pngs() {
        let dir = dir("others");
        let points = [
            SweepPoint {
                cycle_us: 100.0,
                cpu_load: 0.59,
                ldac_max_us: 0.9,
                sustained: true,
            },
            SweepPoint {
                cycle_us: 70.0,
                cpu_load: 0.97,
                ldac_max_us: 5.0,
                sustained: false,
            },
        ];
        let sweep = dir.join("sweep.png");
        cycle_sweep(&sweep, &points, Some(72.0), 90.0).unwrap();
        assert_eq!(png_size(&sweep), (WIDTH, 700));
        assert!(cycle_sweep(&sweep, &[], None, 90.0).is_err());
        let hist = dir.join("hist.png");
        latency_histogram(&hist, "t", &[(740, 9000), (750, 900), (840, 100)], 10.0).unwrap();
        assert_eq!(png_size(&hist), (WIDTH, 450));
        assert!(latency_histogram(&hist, "t", &[], 10.0).is_err());
        let tasks = dir.join("tasks.png");
        cpu_per_task(
            &tasks,
            "t",
            &[("pdi".into(), 0.51), ("sync0_dac".into(), 0.065)],
        )
        .unwrap();
        assert_eq!(png_size(&tasks), (WIDTH, 220));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
