//! `cargo xtask bench --opt-levels`: the release settings chosen by measurement. For each
//! setting below (opt-level, and the machine outliner on or off) every product's image and
//! the Cortex-M3 benchmark are built with it (as `cargo --config` overrides and the target's
//! rustflags, in `target/opt-levels`, so the normal build keeps its artifacts) and the table
//! gives, per setting, each image's flash against its product's budget, the process-data
//! cycle's instructions, the minimum DC cycle of formula F1 and the SDO service time. The
//! bus bytes of F1 do not depend on the setting (the virtual board runs the host-compiled
//! application); they are measured once. A product's own setting is in its folder
//! (`firmware::products::ImageBuild`).
//!
//! Not part of `cargo xtask test`: it builds the firmware many times.

use super::{cm3, model, Derived};
use crate::build::{self, target_dir, Profile};
use crate::image;
use crate::util::Result;
use firmware::platform::boot::layout::APP_VECTORS;
use firmware::products::PRODUCTS;
use virtual_board::tools::bus_cost;
use virtual_board::tools::sim;

/// One release setting.
struct Setting {
    opt_level: &'static str,
    outliner: bool,
}

/// The settings compared, in table order: smallest first, fastest last.
const SETTINGS: [Setting; 7] = [
    Setting {
        opt_level: "z",
        outliner: true,
    },
    Setting {
        opt_level: "s",
        outliner: true,
    },
    Setting {
        opt_level: "s",
        outliner: false,
    },
    Setting {
        opt_level: "2",
        outliner: true,
    },
    Setting {
        opt_level: "2",
        outliner: false,
    },
    Setting {
        opt_level: "3",
        outliner: true,
    },
    Setting {
        opt_level: "3",
        outliner: false,
    },
];

impl Setting {
    fn name(&self) -> String {
        let outliner = if self.outliner { "on" } else { "off" };
        format!("opt-level {}, outliner {outliner}", self.opt_level)
    }

    /// The overrides, in their own target directory.
    fn profile(&self) -> Profile {
        Profile {
            target_dir: Some(target_dir().join("opt-levels")),
            ..Profile::with(self.opt_level, self.outliner)
        }
    }
}

/// The figures of one setting.
struct Measured {
    /// Flash of each product's image, in [`PRODUCTS`] order (`None`: it does not link,
    /// larger than the application slot).
    flash: Vec<Option<u64>>,
    pdi_outputs: u64,
    pdi_inputs: u64,
    derived: Derived,
    sdo_upload: u64,
}

fn measure(setting: &Setting, bus: &bus_cost::BusReport) -> Result<Measured> {
    let mut flash = Vec::new();
    for product in PRODUCTS {
        let Ok(elf) = build::link(product, &setting.profile()) else {
            eprintln!(
                "[bench --opt-levels] {}: does not link with this setting (the linker's \
                 message above)",
                product.name
            );
            flash.push(None);
            continue;
        };
        let data =
            std::fs::read(&elf).map_err(|e| format!("cannot read {}: {e}", elf.display()))?;
        let map = crate::mcu::of(product.board.mcu()).map;
        let sections = image::sections_in(&data, &map).map_err(|e| e.to_string())?;
        let base = match product.board.mcu().has_bootloader() {
            true => u64::from(APP_VECTORS),
            false => map.flash.start,
        };
        flash.push(Some(image::usage(&sections, base).flash));
    }
    let cpu = cm3::measure(1, &setting.profile())?;
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
    let products: Vec<String> = PRODUCTS
        .iter()
        .map(|p| format!("{} (budget {} KB)", p.name, p.budget.flash / 1024))
        .collect();
    let mut lines = vec![
        format!(
            "| release setting | {} | pdi_outputs | pdi_inputs | I_cycle (F1) | F1 minimum DC cycle | ADC share (F3) | sdo_upload |",
            products.join(" | ")
        ),
        format!("|---|{}---|---|---|---|---|---|", "---|".repeat(PRODUCTS.len())),
    ];
    for (i, setting) in SETTINGS.iter().enumerate() {
        eprintln!(
            "[bench --opt-levels] {}/{}: {}",
            i + 1,
            SETTINGS.len(),
            setting.name()
        );
        let m = measure(setting, &bus)?;
        let flash: Vec<String> = PRODUCTS
            .iter()
            .zip(&m.flash)
            .map(|(p, used)| {
                let budget = build::budget_of(p).flash;
                match used.map(|u| (u, budget.checked_sub(u))) {
                    Some((used, Some(free))) => format!("{used} B ({free} B free)"),
                    Some((used, None)) => format!("{used} B (**{} B over**)", used - budget),
                    None => "**does not link** (over the application slot)".to_string(),
                }
            })
            .collect();
        lines.push(format!(
            "| {} | {} | {} | {} | {} | {:.1} us | {:.1} % | {} = {:.1} us |",
            setting.name(),
            flash.join(" | "),
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
    fn settings_build_apart_with_their_outliner() {
        let p = SETTINGS[0].profile();
        assert_eq!(p.config, ["profile.release.opt-level=\"z\""]);
        assert!(p.rustflags.unwrap().contains("machine-outliner"));
        assert!(p.target_dir.unwrap().ends_with("opt-levels"));
        let fast = SETTINGS[SETTINGS.len() - 1].profile();
        assert_eq!(fast.config, ["profile.release.opt-level=3"]);
        assert_eq!(fast.rustflags.as_deref(), Some(""));
    }
}
