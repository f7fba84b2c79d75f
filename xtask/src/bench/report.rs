//! The bench table: rows grouped as in BRIEF section 6, printed as markdown or JSON.

/// The six groups of the issue, in order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Group {
    Bus,
    Cpu,
    Derived,
    Footprint,
    Adc,
    Loopback,
    Image,
    Frames,
}

impl Group {
    /// Number and title.
    pub fn title(self) -> (u8, &'static str) {
        match self {
            Self::Bus => (1, "PDI bus cost (virtual board, ET1100 SPI at 12.5 MHz)"),
            Self::Cpu => (2, "CPU cost on a Cortex-M3 (QEMU, instruction count)"),
            Self::Derived => (
                3,
                "Cycle time and latency (formulas from 1 and 2; measured on the image)",
            ),
            Self::Footprint => (4, "Footprint of the release firmware"),
            Self::Adc => (5, "ADC"),
            Self::Loopback => (6, "Thesis loop-back on the virtual board"),
            Self::Image => (
                7,
                "The release image on the co-simulated LPC1754, per task and per cycle time",
            ),
            Self::Frames => (8, "Frames on a network interface (sim --image --iface)"),
        }
    }
}

/// Whether a figure meets its target.
#[derive(Debug, Clone, PartialEq)]
pub enum Verdict {
    /// Target met (with an optional note).
    Met(String),
    /// Target missed, with the cause.
    Missed(String),
    /// No target: a measured figure (with an optional note).
    Info(String),
    /// Could not be measured here, with the reason.
    NotMeasured(String),
}

impl Verdict {
    fn text(&self) -> String {
        let with = |word: &str, note: &str| {
            if note.is_empty() {
                word.to_string()
            } else {
                format!("{word} ({note})")
            }
        };
        match self {
            Self::Met(n) => with("met", n),
            Self::Missed(c) => with("**missed**", c),
            Self::Info(n) => with("measured", n),
            Self::NotMeasured(n) => with("**not measured**", n),
        }
    }

    fn status(&self) -> &'static str {
        match self {
            Self::Met(_) => "met",
            Self::Missed(_) => "missed",
            Self::Info(_) => "measured",
            Self::NotMeasured(_) => "not_measured",
        }
    }

    fn note(&self) -> &str {
        match self {
            Self::Met(n) | Self::Missed(n) | Self::Info(n) | Self::NotMeasured(n) => n,
        }
    }
}

/// One figure.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    pub group: Group,
    pub figure: String,
    pub value: String,
    pub target: String,
    pub anchor: String,
    pub verdict: Verdict,
    /// The main number of the value, with its unit (for JSON).
    pub number: Option<(f64, &'static str)>,
}

impl Row {
    pub fn new(
        group: Group,
        figure: String,
        value: String,
        target: String,
        anchor: String,
        verdict: Verdict,
    ) -> Self {
        Self {
            group,
            figure,
            value,
            target,
            anchor,
            verdict,
            number: None,
        }
    }

    /// A formula row next to the image's measurement of the same figure: the image row is
    /// judged against the target; this one keeps its figure and what the model says, as a
    /// measured figure without a verdict of its own.
    pub fn into_model(mut self) -> Self {
        let said = match &self.verdict {
            Verdict::Info(n) | Verdict::NotMeasured(n) => n.clone(),
            v => format!("the model alone: {}", v.text()),
        };
        self.verdict = Verdict::Info(format!(
            "model; the image row is the measurement. {}",
            said.replace("**", "")
        ));
        self
    }

    pub fn with_number(mut self, value: f64, unit: &'static str) -> Self {
        self.number = Some((value, unit));
        self
    }
}

fn cell(s: &str) -> String {
    s.replace('|', "\\|")
}

/// The table with its notes.
pub fn markdown(rows: &[Row], notes: &[String], quick: bool, qemu: &str) -> String {
    let mut s = String::new();
    s.push_str(&format!(
        "Performance ({}; {qemu})\n\n",
        if quick {
            "cargo xtask bench --quick: short run"
        } else {
            "cargo xtask bench"
        }
    ));
    s.push_str("| # | Figure | Value | Target | Anchor | Result |\n");
    s.push_str("|---|---|---|---|---|---|\n");
    for r in rows {
        let (n, _) = r.group.title();
        s.push_str(&format!(
            "| {n} | {} | {} | {} | {} | {} |\n",
            cell(&r.figure),
            cell(&r.value),
            cell(&r.target),
            cell(&r.anchor),
            cell(&r.verdict.text())
        ));
    }
    s.push_str("\nGroups: ");
    let groups = [
        Group::Bus,
        Group::Cpu,
        Group::Derived,
        Group::Footprint,
        Group::Adc,
        Group::Loopback,
        Group::Image,
        Group::Frames,
    ];
    s.push_str(
        &groups
            .iter()
            .map(|g| {
                let (n, t) = g.title();
                format!("{n} {t}")
            })
            .collect::<Vec<_>>()
            .join("; "),
    );
    s.push_str(".\n\n");
    for n in notes {
        s.push_str(&format!("- {n}\n"));
    }
    s
}

/// Every row and note as JSON (numbers that are not finite become `null`).
pub fn json(rows: &[Row], notes: &[String], quick: bool) -> String {
    let rows: Vec<serde_json::Value> = rows
        .iter()
        .map(|r| {
            let (n, title) = r.group.title();
            let mut row = serde_json::json!({
                "group": n,
                "group_title": title,
                "figure": r.figure,
                "value": r.value,
                "target": r.target,
                "anchor": r.anchor,
                "status": r.verdict.status(),
                "note": r.verdict.note(),
            });
            if let Some((value, unit)) = r.number {
                row["number"] = serde_json::json!(value);
                row["unit"] = serde_json::json!(unit);
            }
            row
        })
        .collect();
    let doc = serde_json::json!({ "quick": quick, "rows": rows, "notes": notes });
    let mut text = serde_json::to_string_pretty(&doc).unwrap_or_default();
    text.push('\n');
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rows() -> Vec<Row> {
        vec![
            Row::new(
                Group::Bus,
                "a|b".into(),
                "1 B".into(),
                "<= 2 B".into(),
                "x".into(),
                Verdict::Met(String::new()),
            )
            .with_number(1.0, "B"),
            Row::new(
                Group::Derived,
                "c".into(),
                "3 us".into(),
                "<= 2 us".into(),
                "y".into(),
                Verdict::Missed("too \"slow\"".into()),
            ),
            Row::new(
                Group::Bus,
                "d".into(),
                "-".into(),
                "-".into(),
                "z".into(),
                Verdict::NotMeasured("no object".into()),
            ),
        ]
    }

    #[test]
    fn markdown_has_one_row_per_figure_and_says_missed() {
        let md = markdown(&rows(), &["note".into()], true, "QEMU 7.2");
        let table: Vec<&str> = md.lines().filter(|l| l.starts_with("| ")).collect();
        assert_eq!(table.len(), 4); // header + 3
        assert!(table[1].contains("a\\|b"));
        assert!(table[2].contains("**missed** (too \"slow\")"));
        assert!(table[3].contains("**not measured** (no object)"));
        assert!(md.contains("- note"));
    }

    #[test]
    fn json_lists_every_row() {
        let mut rows = rows();
        rows.push(rows[0].clone().with_number(f64::NAN, "us"));
        let j: serde_json::Value =
            serde_json::from_str(&json(&rows, &["n".into()], false)).unwrap();
        assert_eq!(j["quick"], false);
        let r = j["rows"].as_array().unwrap();
        assert_eq!(r.len(), 4);
        assert_eq!(r[0]["figure"], "a|b");
        assert_eq!(
            (r[0]["number"].as_f64(), r[0]["unit"].as_str()),
            (Some(1.0), Some("B"))
        );
        assert_eq!(r[1]["status"], "missed");
        assert_eq!(r[1]["note"], "too \"slow\"");
        assert!(r[1].get("number").is_none());
        assert_eq!(r[2]["status"], "not_measured");
        assert_eq!(r[2]["group"], 1);
        assert!(r[3]["number"].is_null(), "not finite: null");
        assert_eq!(j["notes"], serde_json::json!(["n"]));
    }
}
