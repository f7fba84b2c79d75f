//! The minimum cycle the module advertises (0x1C32:05/0x1C33:05, the ESI:
//! `firmware::products::analog_io::sync::MIN_CYCLE_TIME_NS`) against the minimum DC cycle the bench
//! measures: the constant must be at least the measured figure plus the product's margin
//! (`MIN_CYCLE_MARGIN_PERCENT`), and at least the minimum measured with the time model's
//! cycles per instruction 20 % higher (the sensitivity run, which is where the margin comes
//! from), or a master that trusts it configures a cycle the module cannot hold.

use super::report::{Group, Row, Verdict};
use firmware::products::analog_io::sync::{MIN_CYCLE_MARGIN_PERCENT, MIN_CYCLE_TIME_NS};

/// The advertised figure checked against a measurement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MinCycle {
    /// What the module advertises (us).
    pub advertised_us: f64,
    /// The measured minimum DC cycle (us).
    pub measured_us: f64,
    /// The margin the advertised figure must keep (percent).
    pub margin_percent: u32,
    /// The minimum DC cycle with the time model's CPI 20 % higher, if it was run.
    pub dearer_cpi: Option<DearerCpi>,
}

/// The sensitivity run with the dearer CPI.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DearerCpi {
    /// Cycles per instruction (numerator, denominator).
    pub cpi: (u64, u64),
    /// The shortest DC cycle sustained (us); `None`: none of the cycle times tried.
    pub measured_us: Option<f64>,
}

impl MinCycle {
    /// The product's constants against `measured_us`.
    pub fn of_product(measured_us: f64) -> Self {
        Self {
            advertised_us: f64::from(MIN_CYCLE_TIME_NS) / 1e3,
            measured_us,
            margin_percent: MIN_CYCLE_MARGIN_PERCENT,
            dearer_cpi: None,
        }
    }

    /// With the sensitivity run's figure.
    pub fn with_dearer_cpi(self, dearer_cpi: Option<DearerCpi>) -> Self {
        Self { dearer_cpi, ..self }
    }

    /// The longest measured minimum cycle the product's advertised figure still covers with
    /// its margin (whole us): the cycle time the measurement must sustain for the rule to hold.
    pub fn product_allows_us() -> u64 {
        let advertised = u64::from(MIN_CYCLE_TIME_NS) / 1000;
        advertised * 100 / (100 + u64::from(MIN_CYCLE_MARGIN_PERCENT))
    }

    /// The least the module may advertise: the measurement plus the margin, and the
    /// measurement at the dearer CPI (a run that sustained nothing allows nothing).
    pub fn required_us(&self) -> f64 {
        let with_margin = self.measured_us * (1.0 + f64::from(self.margin_percent) / 100.0);
        match self.dearer_cpi {
            Some(d) => with_margin.max(d.measured_us.unwrap_or(f64::INFINITY)),
            None => with_margin,
        }
    }

    /// The advertised figure is below the measurement plus the margin.
    pub fn too_low(&self) -> bool {
        self.advertised_us < self.required_us()
    }

    /// An error naming the constant to raise when the advertised figure is too low.
    pub fn check(&self) -> crate::util::Result {
        if self.too_low() {
            return Err(format!(
                "the advertised minimum cycle ({:.1} us, firmware::products::analog_io::sync::MIN_CYCLE_TIME_NS) \
                 is below the measured minimum DC cycle plus the margin, or below the minimum \
                 with the time model's CPI 20 % higher ({:.1} us): see the table",
                self.advertised_us,
                self.required_us()
            ));
        }
        Ok(())
    }

    /// The smallest whole microsecond the rule allows.
    fn suggestion_us(&self) -> f64 {
        self.required_us().ceil()
    }

    /// The table row.
    pub fn row(&self) -> Row {
        let verdict = if !self.required_us().is_finite() {
            Verdict::Missed(
                "with the time model's CPI 20 % higher none of the cycle times tried was \
                 sustained"
                    .into(),
            )
        } else if self.too_low() {
            Verdict::Missed(format!(
                "advertised figure too low: a master may configure a cycle the module cannot \
                 hold; set firmware::products::analog_io::sync::MIN_CYCLE_TIME_NS to at least {:.0} us",
                self.suggestion_us()
            ))
        } else if self.advertised_us > self.suggestion_us() + 1.0 {
            Verdict::Met(format!(
                "the rule allows {:.0} us: lower MIN_CYCLE_TIME_NS to offer shorter cycles",
                self.suggestion_us()
            ))
        } else {
            Verdict::Met(String::new())
        };
        Row::new(
            Group::Derived,
            "advertised minimum cycle (0x1C32:05, 0x1C33:05, ESI; MIN_CYCLE_TIME_NS)".into(),
            format!("{:.1} us", self.advertised_us),
            format!(
                ">= {:.1} us (minimum DC cycle {:.1} us + {} %{})",
                self.required_us(),
                self.measured_us,
                self.margin_percent,
                self.dearer_cpi.map_or(String::new(), |d| format!(
                    "; at CPI {}/{}: {}",
                    d.cpi.0,
                    d.cpi.1,
                    d.measured_us
                        .map_or("none sustained".into(), |us| format!("{us:.1} us"))
                ))
            ),
            "the module's promise to masters".into(),
            verdict,
        )
        .with_number(self.advertised_us, "us")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(advertised_us: f64, measured_us: f64) -> MinCycle {
        MinCycle {
            advertised_us,
            measured_us,
            margin_percent: 15,
            dearer_cpi: None,
        }
    }

    #[test]
    fn the_advertised_figure_covers_the_dearer_cpi_too() {
        let dearer = |us| {
            Some(DearerCpi {
                cpi: (3, 2),
                measured_us: us,
            })
        };
        let c = check(50.0, 40.0).with_dearer_cpi(dearer(Some(45.0)));
        assert!((c.required_us() - 46.0).abs() < 1e-9, "the margin rules");
        let c = check(50.0, 40.0).with_dearer_cpi(dearer(Some(49.0)));
        assert!((c.required_us() - 49.0).abs() < 1e-9);
        assert!(!c.too_low());
        assert!(
            c.row().target.contains("at CPI 3/2: 49.0 us"),
            "{}",
            c.row().target
        );
        assert!(check(50.0, 40.0)
            .with_dearer_cpi(dearer(Some(51.0)))
            .too_low());
        let none = check(50.0, 40.0).with_dearer_cpi(dearer(None));
        assert!(none.too_low());
        assert!(none.row().target.contains("none sustained"));
    }

    #[test]
    fn the_advertised_figure_keeps_the_margin() {
        assert!((check(50.0, 40.0).required_us() - 46.0).abs() < 1e-9);
        assert!(!check(50.0, 40.0).too_low());
        assert!(!check(46.0, 40.0).too_low());
        assert!(check(45.9, 40.0).too_low());
        let row = check(25.0, 42.2).row();
        assert!(matches!(&row.verdict, Verdict::Missed(why)
            if why.contains("too low") && why.contains("at least 49 us")));
        assert!(matches!(check(50.0, 42.2).row().verdict, Verdict::Met(ref n) if n.is_empty()));
        assert!(matches!(check(80.0, 42.2).row().verdict,
            Verdict::Met(ref n) if n.contains("allows 49 us")));
    }

    #[test]
    fn the_product_keeps_its_own_rule_against_its_constants() {
        let c = MinCycle::of_product(0.0);
        assert_eq!(c.advertised_us, f64::from(MIN_CYCLE_TIME_NS) / 1e3);
        assert_eq!(c.margin_percent, MIN_CYCLE_MARGIN_PERCENT);
        // A measurement at the cycle the product allows keeps the rule; 1 us more breaks it.
        let allows = MinCycle::product_allows_us() as f64;
        assert!(!MinCycle::of_product(allows).too_low());
        assert!(MinCycle::of_product(allows + 1.0).too_low());
    }
}
