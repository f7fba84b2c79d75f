//! The flash map of the module (LPC1754: 128 KB, sectors 0..15 of 4 KB, 16..17 of 32 KB) and
//! the RAM word the application and the bootloader share: defined here once. The linker
//! scripts (`memory-app.x` of the application, `memory-boot.x` of the bootloader, both
//! included through the root `memory.x`) repeat the numbers a linker needs; a test reads
//! them back and compares.
//!
//! | Region | Addresses | Sectors | What |
//! |---|---|---|---|
//! | bootloader | 0x0000_0000..0x0000_3000 | 0..=2 | vectors (checksum at 0x1C), CRP word at 0x2FC, the bootloader |
//! | application slot | 0x0000_3000..0x0001_0000 | 3..=15 | header block (256 B), then the application's vectors at 0x3100 |
//! | staging area | 0x0001_0000..0x0002_0000 | 16..=17 | a received update file, header block first |
//!
//! The update file (`.efw`) is the application slot's content: the header block, then the
//! image linked at [`APP_VECTORS`]. Files are moved in [`CHUNK`]s (the ROM's copy size): the
//! first chunk, which holds the header, is always written last.

use coe_core::device::MemoryWindow;
use lpc17xx_iap::sector;

/// An address range of the flash.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Region {
    /// First address.
    pub start: u32,
    /// Bytes.
    pub len: u32,
}

impl Region {
    /// One past the last address.
    pub const fn end(&self) -> u32 {
        self.start + self.len
    }

    /// First and last sector.
    pub const fn sectors(&self) -> (u32, u32) {
        match sector::sectors_spanning(self.start, self.len) {
            Some(s) => s,
            None => (0, 0),
        }
    }
}

/// The bootloader: the first three sectors. Not the brief's 8 KB: the bootloader reuses
/// the application's ESM and mailbox link and coe-core's FoE server, which together with
/// the ESC driver, the IAP calls and the image checks take about 11 KB; the slot still
/// holds more than the application's budget.
pub const BOOTLOADER: Region = Region {
    start: 0x0000_0000,
    len: 0x3000,
};

/// The application slot: header block, then the application.
pub const APP_SLOT: Region = Region {
    start: 0x0000_3000,
    len: 0xD000,
};

/// The staging area: where a received update file waits for its check and installation.
pub const STAGING: Region = Region {
    start: 0x0001_0000,
    len: 0x1_0000,
};

/// Bytes of the header block at the start of the slot (and of the file).
pub const HEADER_BLOCK: u32 = 256;

/// Size of the bootstrap mailbox (BOOT state, each direction): four times the standard
/// mailbox, so an update file moves in packets of 500 bytes.
pub const BOOTSTRAP_MAILBOX_SIZE: usize = 512;

/// SyncManager control bytes of the mailboxes (ETG.1000.4: mailbox mode, ECAT write / PDI
/// read with the PDI interrupt; ECAT read / PDI write): the bootstrap mailbox's, which the
/// bootloader checks at INIT -> BOOT, and every product's standard mailbox's.
pub const MAILBOX_CONTROL: (u8, u8) = (0x26, 0x22);

/// The bootloader's mailbox in the ESC (BOOT state, FoE only; every product's SII words
/// 0x14..0x17 and ESI `BootStrap` give it): master -> slave at 0x1000, slave -> master
/// right after it. A product's process-data buffers it covers are not in use in BOOT.
pub const BOOTSTRAP_MAILBOX: (MemoryWindow, MemoryWindow) = (
    MemoryWindow::new(0x1000, BOOTSTRAP_MAILBOX_SIZE as u16),
    MemoryWindow::new(
        0x1000 + BOOTSTRAP_MAILBOX_SIZE as u16,
        BOOTSTRAP_MAILBOX_SIZE as u16,
    ),
);

/// Where the application's vector table (its first byte) lies: after the header block,
/// aligned as VTOR needs (LPC17xx: 51 vectors -> 256 bytes).
pub const APP_VECTORS: u32 = APP_SLOT.start + HEADER_BLOCK;

/// The largest image a file may carry (the slot minus the header block).
pub const MAX_IMAGE: u32 = APP_SLOT.len - HEADER_BLOCK;

/// Unit of staging writes and installation copies (an IAP copy size; slot, staging area
/// and files are moved in whole chunks, padded with 0xFF).
pub const CHUNK: usize = 1024;

/// A RAM buffer of one chunk, word-aligned as the IAP ROM needs its source.
#[derive(Debug, Clone)]
#[repr(C, align(4))]
pub struct Chunk(pub [u8; CHUNK]);

impl Chunk {
    /// All bytes erased (0xFF).
    pub const fn erased() -> Self {
        Self([0xFF; CHUNK])
    }
}

/// Flash budget of the bootloader (brief 6): its whole region.
pub const BOOTLOADER_BUDGET: u32 = BOOTLOADER.len;

/// Flash budget of any product's application image (brief 6: at most 48 KB; each product
/// has its own within it, `crate::products`); the slot leaves room beyond it.
pub const APP_BUDGET: u32 = 48 * 1024;

/// The boot request word (two u32: a magic and its complement, [`crate::platform::boot::request`]):
/// the last 8 bytes of the local SRAM below the 32 bytes the IAP ROM uses. Both linker
/// scripts end their RAM region here, so no static or stack of either program lies on it.
pub const BOOT_REQUEST_ADDR: u32 = 0x1000_3FD8;

/// End of the local SRAM the programs may use for statics and stack: the boot request word.
pub const RAM_END: u32 = BOOT_REQUEST_ADDR;

/// First address of the local SRAM.
pub const RAM_START: u32 = 0x1000_0000;

const _: () = {
    // The regions tile the flash in whole sectors, in this order.
    assert!(BOOTLOADER.end() == APP_SLOT.start && APP_SLOT.end() == STAGING.start);
    assert!(STAGING.end() == sector::FLASH_SIZE);
    assert!(BOOTLOADER.sectors().0 == 0 && BOOTLOADER.sectors().1 == 2);
    assert!(APP_SLOT.sectors().0 == 3 && APP_SLOT.sectors().1 == 15);
    assert!(STAGING.sectors().0 == 16 && STAGING.sectors().1 == 17);
    // A whole file fits the staging area, the budget fits the slot.
    assert!(APP_SLOT.len <= STAGING.len && APP_BUDGET <= MAX_IMAGE);
    // Chunks tile both; the vector table is 256-byte aligned.
    assert!(APP_SLOT.len % CHUNK as u32 == 0 && STAGING.len % CHUNK as u32 == 0);
    assert!(APP_VECTORS % 256 == 0 && HEADER_BLOCK as usize <= CHUNK);
    // The request word lies in the local SRAM, below the ROM's 32 bytes.
    assert!(BOOT_REQUEST_ADDR + 8 <= lpc17xx_iap::iap::IAP_RAM_START);
};

#[cfg(test)]
mod tests {
    use super::*;
    use std::string::String;

    /// `NAME : ORIGIN = 0x..., LENGTH = ...` of a MEMORY block, as bytes.
    fn region(script: &str, name: &str) -> (u32, u32) {
        let line = script
            .lines()
            .map(str::trim)
            .find(|l| l.starts_with(name) && l.contains("ORIGIN"))
            .unwrap_or_else(|| panic!("no {name} in the script"));
        let value = |key: &str| -> u32 {
            let after = line.split(key).nth(1).unwrap();
            let v = after
                .trim_start_matches([' ', '='])
                .split([',', ' '])
                .next()
                .unwrap();
            if let Some(hex) = v.strip_prefix("0x") {
                u32::from_str_radix(hex, 16).unwrap()
            } else if let Some(k) = v.strip_suffix('K') {
                k.parse::<u32>().unwrap() * 1024
            } else {
                v.parse().unwrap()
            }
        };
        (value("ORIGIN"), value("LENGTH"))
    }

    fn script(name: &str) -> String {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("..")
            .join(name);
        std::fs::read_to_string(&path).unwrap()
    }

    #[test]
    fn the_linker_scripts_follow_the_layout() {
        let app = script("memory-app.x");
        assert_eq!(
            region(&app, "FLASH"),
            (APP_VECTORS, APP_SLOT.end() - APP_VECTORS)
        );
        assert_eq!(region(&app, "RAM"), (RAM_START, RAM_END - RAM_START));
        let boot = script("memory-boot.x");
        assert_eq!(region(&boot, "FLASH"), (BOOTLOADER.start, BOOTLOADER.len));
        assert_eq!(region(&boot, "RAM"), (RAM_START, RAM_END - RAM_START));
    }
}
