//! EtherCAT State Machine (ETG.1000.6 section 6.4; ESC datasheet section I, figure "ESM").

/// An ESM state as written to AL control (0x0120 bits 3:0) and AL status (0x0130 bits 3:0).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AlState {
    /// INIT (1): no mailbox, no process data.
    Init = 1,
    /// PRE-OPERATIONAL (2): mailbox active.
    PreOp = 2,
    /// BOOTSTRAP (3): firmware update over FoE.
    Bootstrap = 3,
    /// SAFE-OPERATIONAL (4): inputs valid, outputs in safe state.
    SafeOp = 4,
    /// OPERATIONAL (8): inputs and outputs valid.
    Op = 8,
}

impl AlState {
    /// Decodes the state nibble; `None` for a value that names no state (AL status code 0x0012).
    pub const fn from_nibble(value: u8) -> Option<Self> {
        match value & 0x0F {
            1 => Some(Self::Init),
            2 => Some(Self::PreOp),
            3 => Some(Self::Bootstrap),
            4 => Some(Self::SafeOp),
            8 => Some(Self::Op),
            _ => None,
        }
    }

    /// The state nibble.
    pub const fn nibble(self) -> u8 {
        self as u8
    }
}
