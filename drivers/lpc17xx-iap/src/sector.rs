//! The LPC1754 flash: 128 KB at 0, sectors 0..15 of 4 KB (0x0000_0000..0x0000_FFFF) and
//! 16..17 of 32 KB (0x0001_0000..0x0001_FFFF) (UM10360 32.5 table "sectors in LPC17xx";
//! hardware-facts sections 7 and 9). IAP commands take sector numbers, not addresses.

/// First flash address.
pub const FLASH_START: u32 = 0x0000_0000;
/// Flash size of the LPC1754.
pub const FLASH_SIZE: u32 = 128 * 1024;
/// Size of sectors 0..15.
pub const SMALL_SECTOR_SIZE: u32 = 4 * 1024;
/// Number of 4 KB sectors (they cover the first 64 KB).
pub const SMALL_SECTORS: u32 = 16;
/// Size of sectors 16 and up.
pub const LARGE_SECTOR_SIZE: u32 = 32 * 1024;
/// Number of sectors of the LPC1754 (0..=17).
pub const SECTOR_COUNT: u32 = 18;
/// The last sector number.
pub const LAST_SECTOR: u32 = SECTOR_COUNT - 1;

/// End of the 4 KB sectors.
const SMALL_END: u32 = SMALL_SECTORS * SMALL_SECTOR_SIZE;

/// A run of equally sized sectors, as a target description lists them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SectorRun {
    /// Sector size in bytes.
    pub size: u32,
    /// Address of the first sector of the run.
    pub address: u32,
}

/// The sector layout as runs: 4 KB from 0, 32 KB from 0x1_0000.
pub const SECTOR_RUNS: [SectorRun; 2] = [
    SectorRun {
        size: SMALL_SECTOR_SIZE,
        address: FLASH_START,
    },
    SectorRun {
        size: LARGE_SECTOR_SIZE,
        address: SMALL_END,
    },
];

/// The sector holding `addr`, `None` outside the flash.
pub const fn sector_of(addr: u32) -> Option<u32> {
    if addr >= FLASH_START + FLASH_SIZE {
        None
    } else if addr < SMALL_END {
        Some(addr / SMALL_SECTOR_SIZE)
    } else {
        Some(SMALL_SECTORS + (addr - SMALL_END) / LARGE_SECTOR_SIZE)
    }
}

/// First address of sector `n`, `None` for a sector the LPC1754 does not have.
pub const fn sector_start(n: u32) -> Option<u32> {
    if n > LAST_SECTOR {
        None
    } else if n < SMALL_SECTORS {
        Some(n * SMALL_SECTOR_SIZE)
    } else {
        Some(SMALL_END + (n - SMALL_SECTORS) * LARGE_SECTOR_SIZE)
    }
}

/// Size of sector `n`.
pub const fn sector_size(n: u32) -> Option<u32> {
    if n > LAST_SECTOR {
        None
    } else if n < SMALL_SECTORS {
        Some(SMALL_SECTOR_SIZE)
    } else {
        Some(LARGE_SECTOR_SIZE)
    }
}

/// Whether `[addr, addr + len)` lies inside the flash (`len` 0 is inside when `addr` is at
/// most the end).
pub const fn in_flash(addr: u32, len: u32) -> bool {
    match addr.checked_add(len) {
        // The flash starts at address 0, so only the end can be outside.
        Some(end) => end <= FLASH_START + FLASH_SIZE,
        None => false,
    }
}

/// First and last sector touched by `len > 0` bytes at `addr`; `None` when outside.
pub const fn sectors_spanning(addr: u32, len: u32) -> Option<(u32, u32)> {
    if len == 0 || !in_flash(addr, len) {
        return None;
    }
    match (sector_of(addr), sector_of(addr + (len - 1))) {
        (Some(first), Some(last)) => Some((first, last)),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_address_maps_to_the_sector_that_contains_it() {
        // Walk the whole flash word by word and compare with the table built from the sizes.
        let mut expected = 0u32;
        let mut next_start = SMALL_SECTOR_SIZE;
        for addr in (0..FLASH_SIZE).step_by(4) {
            if addr == next_start {
                expected += 1;
                next_start += sector_size(expected).unwrap();
            }
            assert_eq!(sector_of(addr), Some(expected), "{addr:#x}");
            assert_eq!(sector_of(addr + 3), Some(expected), "{:#x}", addr + 3);
        }
        assert_eq!(expected, LAST_SECTOR);
        assert_eq!(next_start, FLASH_SIZE);
    }

    #[test]
    fn boundaries() {
        for (addr, sector) in [
            (0x0000_0000, 0),
            (0x0000_0FFF, 0),
            (0x0000_1000, 1),
            (0x0000_02FC, 0), // the CRP word
            (0x0000_EFFF, 14),
            (0x0000_F000, 15),
            (0x0000_FFFF, 15),
            (0x0001_0000, 16),
            (0x0001_7FFF, 16),
            (0x0001_8000, 17),
            (0x0001_FFFF, 17),
        ] {
            assert_eq!(sector_of(addr), Some(sector), "{addr:#x}");
        }
        for addr in [0x0002_0000, 0x0002_0001, 0x1000_0000, u32::MAX] {
            assert_eq!(sector_of(addr), None, "{addr:#x}");
        }
    }

    #[test]
    fn starts_and_sizes_tile_the_flash() {
        let mut addr = 0;
        for n in 0..SECTOR_COUNT {
            assert_eq!(sector_start(n), Some(addr));
            assert_eq!(sector_of(addr), Some(n));
            addr += sector_size(n).unwrap();
        }
        assert_eq!(addr, FLASH_SIZE);
        assert_eq!(sector_start(18), None);
        assert_eq!(sector_size(18), None);
        assert_eq!(sector_start(u32::MAX), None);
        assert_eq!(sector_start(16), Some(0x1_0000));
        assert_eq!(sector_start(17), Some(0x1_8000));
    }

    #[test]
    fn runs_match_the_table() {
        for run in SECTOR_RUNS {
            let n = sector_of(run.address).unwrap();
            assert_eq!(sector_start(n), Some(run.address));
            assert_eq!(sector_size(n), Some(run.size));
        }
    }

    #[test]
    fn ranges() {
        assert!(in_flash(0, FLASH_SIZE));
        assert!(in_flash(FLASH_SIZE, 0));
        assert!(!in_flash(FLASH_SIZE - 4, 8));
        assert!(!in_flash(u32::MAX, 2)); // overflow
        assert_eq!(sectors_spanning(0, 1), Some((0, 0)));
        assert_eq!(sectors_spanning(0xF00, 0x200), Some((0, 1)));
        assert_eq!(sectors_spanning(0xF000, 0x1_1000), Some((15, 17)));
        assert_eq!(sectors_spanning(0, 0), None);
        assert_eq!(sectors_spanning(0x1_FF00, 0x200), None);
    }
}
