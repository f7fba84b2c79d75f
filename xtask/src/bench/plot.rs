//! The loop-back figure: per frequency one panel (top to bottom in the order run), input
//! sine in blue and DAC output in red over a few periods, 0..10 V, with grid lines every
//! 2.5 V and every period; like the thesis' oscilloscope pictures. No text is drawn (the
//! bitmap backend would need system fonts); the README and `--json` say what is where.

use crate::util::Result;
use plotters::prelude::*;
use std::path::Path;

/// One panel: time in ms from the start of the shown window, volts.
#[derive(Debug, Clone, PartialEq)]
pub struct Trace {
    /// Input frequency (Hz).
    pub freq_hz: f64,
    /// Input (sampled).
    pub input: Vec<(f64, f64)>,
    /// DAC output (as steps: two points per load).
    pub output: Vec<(f64, f64)>,
}

/// Panel size in pixels.
const WIDTH: u32 = 1000;
const PANEL_HEIGHT: u32 = 300;

/// Writes the PNG.
pub fn write_png(path: &Path, traces: &[Trace]) -> Result {
    if traces.is_empty() {
        return Err("nothing to plot".into());
    }
    let err = |e: &dyn std::fmt::Display| format!("plot {}: {e}", path.display());
    let root =
        BitMapBackend::new(path, (WIDTH, PANEL_HEIGHT * traces.len() as u32)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let panels = root.split_evenly((traces.len(), 1));
    for (area, t) in panels.iter().zip(traces) {
        let span = t
            .input
            .iter()
            .chain(&t.output)
            .map(|p| p.0)
            .fold(0.0f64, f64::max);
        let mut chart = ChartBuilder::on(area)
            .margin(12)
            .build_cartesian_2d(0.0..span.max(1e-6), 0.0..10.0)
            .map_err(|e| err(&e))?;
        let grey = RGBColor(215, 215, 215);
        for v in [0.0, 2.5, 5.0, 7.5, 10.0] {
            chart
                .draw_series(LineSeries::new([(0.0, v), (span, v)], grey))
                .map_err(|e| err(&e))?;
        }
        let period_ms = 1e3 / t.freq_hz;
        let mut x = 0.0;
        while x <= span + 1e-9 {
            chart
                .draw_series(LineSeries::new([(x, 0.0), (x, 10.0)], grey))
                .map_err(|e| err(&e))?;
            x += period_ms;
        }
        chart
            .draw_series(LineSeries::new(
                t.input.iter().copied(),
                BLUE.stroke_width(2),
            ))
            .map_err(|e| err(&e))?;
        chart
            .draw_series(LineSeries::new(
                t.output.iter().copied(),
                RED.stroke_width(2),
            ))
            .map_err(|e| err(&e))?;
    }
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_a_png_with_one_panel_per_trace() {
        let dir = std::env::temp_dir().join(format!("xtask-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("p.png");
        let sine: Vec<(f64, f64)> = (0..100)
            .map(|i| (i as f64 * 0.2, 5.0 + 4.0 * (i as f64 * 0.2 * 0.314).sin()))
            .collect();
        let t = Trace {
            freq_hz: 50.0,
            input: sine.clone(),
            output: sine,
        };
        write_png(&path, &[t.clone(), t]).unwrap();
        let png = std::fs::read(&path).unwrap();
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
        // IHDR: width and height (two panels).
        assert_eq!(u32::from_be_bytes(png[16..20].try_into().unwrap()), WIDTH);
        assert_eq!(
            u32::from_be_bytes(png[20..24].try_into().unwrap()),
            2 * PANEL_HEIGHT
        );
        assert!(write_png(&path, &[]).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
