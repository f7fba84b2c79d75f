//! The LPC17xx IAP ROM (UM10360 32.8) on the co-simulator: the entry point 0x1FFF_1FF1 is a
//! `bx lr` in a mapped ROM page; when that block runs (not when the run stops at its start
//! and enters it again later), the command the caller's R0 points at is carried out on the
//! LPC1754 models' flash model (`lpc17xx_iap::model::FlashModel`: the ROM's rules, bits only
//! 1 -> 0, the command log), the five result words are written where R1 points, and the
//! engine's flash is refreshed from the model when the command changed it. Every other
//! address of the boot ROM stays unmapped (a call there is a fault).
//!
//! Reported (the run's reports, not faults): a call with interrupts enabled (the ROM needs
//! the flash idle; a handler in flash would fault), a CPU clock argument other than the
//! clock the CPU runs at (the ROM would time its pulses wrong), and what the model records
//! as misuse. Not modelled: the time the ROM takes (the core's clock does not advance
//! during a command) and its use of the top 32 bytes of the local SRAM.

use crate::cpu::Shared;
use lpc17xx_iap::iap::IAP_ENTRY;
use lpc17xx_iap::sector::FLASH_SIZE;
use lpc17xx_iap::{Command, IapEntry};
use unicorn_engine::{Prot, RegisterARM, Unicorn};

/// The ROM page that holds the entry point.
pub const ROM_PAGE: (u32, u32) = (0x1FFF_1000, 0x1000);

/// The entry point's address (without the Thumb bit): where the caller's `blx` lands.
pub const ENTRY: u32 = IAP_ENTRY & !1;

/// `bx lr`.
const BX_LR: [u8; 2] = [0x70, 0x47];

/// Maps the ROM page with the entry point.
pub fn map(uc: &mut Unicorn<'_, Shared>) -> Result<(), String> {
    uc.mem_map(
        u64::from(ROM_PAGE.0),
        u64::from(ROM_PAGE.1),
        Prot::READ | Prot::EXEC,
    )
    .map_err(|e| format!("unicorn: IAP ROM page: {e:?}"))?;
    uc.mem_write(u64::from(ENTRY), &BX_LR)
        .map_err(|e| format!("unicorn: IAP entry: {e:?}"))
}

fn reg(uc: &Unicorn<'_, Shared>, r: RegisterARM) -> u32 {
    uc.reg_read(r).unwrap_or(0) as u32
}

fn words<const N: usize>(uc: &Unicorn<'_, Shared>, addr: u32) -> Option<[u32; N]> {
    let mut b = vec![0u8; 4 * N];
    uc.mem_read(u64::from(addr), &mut b).ok()?;
    let mut w = [0u32; N];
    for (i, c) in b.chunks(4).enumerate() {
        w[i] = u32::from_le_bytes([c[0], c[1], c[2], c[3]]);
    }
    Some(w)
}

/// Carries out the command of the call that is entering the ROM (R0: five command words,
/// R1: five result words).
pub fn call(uc: &mut Unicorn<'_, Shared>) {
    let machine = uc.get_data().clone();
    let (r0, r1) = (reg(uc, RegisterARM::R0), reg(uc, RegisterARM::R1));
    let Some(command) = words::<5>(uc, r0) else {
        machine
            .borrow_mut()
            .report(format!("IAP: command words at {r0:#010x} unreadable"));
        return;
    };
    let source = match Command::source(&command) {
        Some((addr, len)) if len <= 4096 => {
            let mut b = vec![0u8; len as usize];
            if uc.mem_read(u64::from(addr), &mut b).is_err() {
                b.clear();
            }
            b
        }
        _ => Vec::new(),
    };
    let interrupts_on = reg(uc, RegisterARM::PRIMASK) & 1 == 0;
    let (result, changed) = {
        let mut m = machine.borrow_mut();
        let mut problems = Vec::new();
        if interrupts_on {
            problems.push(
                "IAP ROM called with interrupts enabled (the flash is busy during a command)"
                    .to_string(),
            );
        }
        let told = match Command::from(command[0]) {
            Command::EraseSectors => Some(command[3]),
            Command::CopyRamToFlash => Some(command[4]),
            _ => None,
        };
        let cclk_khz = (m.cclk_hz() / 1000) as u32;
        if let Some(told) = told.filter(|t| *t != cclk_khz) {
            problems.push(format!(
                "IAP {}: the ROM was told {told} kHz, the CPU runs at {cclk_khz} kHz",
                Command::from(command[0])
            ));
        }
        // The ROM page is mapped on the LPC1754 alone, whose models hold the flash.
        let Some(lpc) = m.lpc17xx_mut() else {
            return;
        };
        lpc.iap_calls += 1;
        let steps = lpc.flash.steps();
        let seen = lpc.flash.violations().len();
        let result = lpc.flash.call(&command, &source);
        problems.extend(
            lpc.flash.violations()[seen..]
                .iter()
                .map(|v| format!("IAP: {v}")),
        );
        let changed = lpc.flash.steps() != steps;
        for p in problems {
            m.report(p);
        }
        (result, changed)
    };
    let bytes: Vec<u8> = result.iter().flat_map(|w| w.to_le_bytes()).collect();
    if uc.mem_write(u64::from(r1), &bytes).is_err() {
        machine
            .borrow_mut()
            .report(format!("IAP: result words at {r1:#010x} not writable"));
    }
    if changed {
        let flash = machine.borrow().lpc17xx().map(|l| l.flash.flash().to_vec());
        if let Some(flash) = flash {
            let _ = uc.mem_write(0, &flash);
        }
        // Code that ran from the old flash must not run again from the translation cache.
        let _ = uc.ctl_remove_cache(0, u64::from(FLASH_SIZE));
    }
}
