//! `cargo xtask bench --opt-levels`: the release profile's optimisation chosen by
//! measurement. For each setting below the release image and the Cortex-M3 benchmark are
//! built with the setting as `cargo --config` overrides (in `target/opt-levels`, so the
//! normal build keeps its artifacts) and the table gives, per setting, the image's flash
//! against the budget, the process-data cycle's instructions, the minimum DC cycle of
//! formula F1 and the SDO service time. The bus bytes of F1 do not depend on the setting
//! (the virtual board runs the host-compiled application); they are measured once.
//!
//! Not part of `cargo xtask test`: it builds the firmware seven times.

use super::{cm3, model, Derived};
use crate::build::{self, target_dir, Profile};
use crate::image;
use crate::util::Result;
use firmware::platform::boot::layout::APP_VECTORS;
use virtual_board::tools::bus_cost;
use virtual_board::tools::sim;

/// The crates on the process-data path, for the per-package settings.
const HOT: [&str; 4] = ["firmware", "coe-core", "et1100", "ad5663"];

/// One release-profile setting: the base level and, optionally, another level for [`HOT`].
struct Setting {
    base: &'static str,
    hot: Option<&'static str>,
}

/// The settings compared, in table order.
const SETTINGS: [Setting; 7] = [
    Setting {
        base: "\"z\"",
        hot: None,
    },
    Setting {
        base: "\"s\"",
        hot: None,
    },
    Setting {
        base: "2",
        hot: None,
    },
    Setting {
        base: "3",
        hot: None,
    },
    Setting {
        base: "\"z\"",
        hot: Some("3"),
    },
    Setting {
        base: "\"s\"",
        hot: Some("3"),
    },
    Setting {
        base: "\"s\"",
        hot: Some("2"),
    },
];

impl Setting {
    fn name(&self) -> String {
        match self.hot {
            None => format!("opt-level = {}", self.base),
            Some(hot) => format!("opt-level = {}, {} = {hot}", self.base, HOT.join(", ")),
        }
    }

    /// The overrides for a build whose binary crate is `root`. The binary crate gets the
    /// hot level too: link-time optimisation runs at the level of the crate that links, so
    /// the benchmark program must link at the level the firmware binary links at.
    fn profile(&self, root: &str) -> Profile {
        let mut config = vec![format!("profile.release.opt-level={}", self.base)];
        if let Some(hot) = self.hot {
            for krate in HOT.iter().chain((!HOT.contains(&root)).then_some(&root)) {
                config.push(format!("profile.release.package.{krate}.opt-level={hot}"));
            }
        }
        Profile {
            config,
            target_dir: Some(target_dir().join("opt-levels")),
        }
    }
}

/// The figures of one setting.
struct Measured {
    flash: u64,
    pdi_outputs: u64,
    pdi_inputs: u64,
    derived: Derived,
    sdo_upload: u64,
}

fn measure(setting: &Setting, bus: &bus_cost::BusReport) -> Result<Measured> {
    let elf = build::link(&setting.profile("firmware"))?;
    let data = std::fs::read(&elf).map_err(|e| format!("cannot read {}: {e}", elf.display()))?;
    let sections = image::sections(&data).map_err(|e| e.to_string())?;
    let flash = image::usage(&sections, u64::from(APP_VECTORS)).flash;
    let cpu = cm3::measure(1, &setting.profile("bench-cm3"))?;
    Ok(Measured {
        flash,
        pdi_outputs: cpu.get("pdi_outputs")?,
        pdi_inputs: cpu.get("pdi_inputs")?,
        derived: Derived::new(bus, &cpu)?,
        sdo_upload: cpu.get("sdo_upload")?,
    })
}

pub fn run() -> Result {
    let cycle_ns = u64::from(super::CYCLE_US) * 1000;
    eprintln!("[bench --opt-levels] PDI bus cost on the virtual board (once)");
    let bus = bus_cost::measure(sim::firmware_target()?, cycle_ns, 1000)?;
    let budget = image::BUDGET.flash;
    let mut lines = vec![
        "| release profile | flash (budget 48 KB) | pdi_outputs | pdi_inputs | I_cycle (F1) | \
         F1 minimum DC cycle | ADC share (F3) | sdo_upload |"
            .to_string(),
        "|---|---|---|---|---|---|---|---|".to_string(),
    ];
    for (i, setting) in SETTINGS.iter().enumerate() {
        eprintln!(
            "[bench --opt-levels] {}/{}: {}",
            i + 1,
            SETTINGS.len(),
            setting.name()
        );
        let m = measure(setting, &bus)?;
        let fits = if m.flash <= budget {
            format!("{} KB to spare", (budget - m.flash) / 1024)
        } else {
            format!("**{} B over**", m.flash - budget)
        };
        lines.push(format!(
            "| {} | {} B ({fits}) | {} | {} | {} | {:.1} us | {:.1} % | {} = {:.1} us |",
            setting.name(),
            m.flash,
            m.pdi_outputs,
            m.pdi_inputs,
            m.derived.cpu_instructions,
            m.derived.cycle_us,
            100.0 * m.derived.adc_share,
            m.sdo_upload,
            model::cpu_us(m.sdo_upload as f64)
        ));
    }
    println!("{}", lines.join("\n"));
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hot_settings_give_the_linking_crate_the_hot_level_too() {
        let s = Setting {
            base: "\"s\"",
            hot: Some("3"),
        };
        let bench = s.profile("bench-cm3").config;
        assert_eq!(bench[0], "profile.release.opt-level=\"s\"");
        assert!(bench.contains(&"profile.release.package.bench-cm3.opt-level=3".to_string()));
        assert_eq!(bench.len(), 1 + HOT.len() + 1);
        // The firmware binary is one of the hot crates already.
        assert_eq!(s.profile("firmware").config.len(), 1 + HOT.len());
        let plain = SETTINGS[0].profile("firmware");
        assert_eq!(plain.config, ["profile.release.opt-level=\"z\""]);
        assert!(plain.target_dir.unwrap().ends_with("opt-levels"));
    }
}
