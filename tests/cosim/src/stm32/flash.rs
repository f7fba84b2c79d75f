//! FLASH_ACR (RM0008 3.3.3): the wait states and the prefetch buffer. The rule the chip
//! needs: SYSCLK up to 24 MHz with 0 wait states, up to 48 MHz with 1, up to 72 MHz with 2;
//! fewer reads wrong instructions, which the machine reports.

const ACR: u32 = 0x00;

/// FLASH_ACR.
#[derive(Clone, Debug)]
pub struct FlashAcr {
    acr: u32,
}

impl Default for FlashAcr {
    fn default() -> Self {
        Self::new()
    }
}

impl FlashAcr {
    /// Reset: 0 wait states, prefetch on (0x30).
    pub fn new() -> Self {
        Self { acr: 0x30 }
    }

    /// LATENCY.
    pub fn latency(&self) -> u32 {
        self.acr & 7
    }

    /// The wait states SYSCLK `hz` needs.
    pub fn needed(hz: u64) -> u32 {
        match hz {
            0..=24_000_000 => 0,
            24_000_001..=48_000_000 => 1,
            _ => 2,
        }
    }

    /// A register read (the other registers, the FPEC's, are not modelled: 0).
    pub fn read(&self, offset: u32) -> u32 {
        match offset {
            // PRFTBS follows PRFTBE.
            ACR => self.acr & !0x20 | (self.acr & 0x10) << 1,
            _ => 0,
        }
    }

    /// A register write; `Err` for the flash programming registers (no bootloader here).
    pub fn write(&mut self, offset: u32, value: u32) -> Result<(), String> {
        match offset {
            ACR => {
                self.acr = value & 0x1F;
                Ok(())
            }
            other => Err(format!(
                "write of {value:#x} to the flash interface at offset {other:#x}: the FPEC \
                 (flash programming) is not modelled"
            )),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wait_states_per_sysclk() {
        assert_eq!(FlashAcr::needed(8_000_000), 0);
        assert_eq!(FlashAcr::needed(48_000_000), 1);
        assert_eq!(FlashAcr::needed(72_000_000), 2);
        let mut f = FlashAcr::new();
        f.write(ACR, 0x12).unwrap();
        assert_eq!(f.latency(), 2);
        assert_eq!(f.read(ACR), 0x32, "PRFTBS follows PRFTBE");
    }
}
