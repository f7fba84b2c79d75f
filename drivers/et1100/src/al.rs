//! Application layer registers: AL event request (0x0220), AL control (0x0120),
//! AL status (0x0130) (ESC-II 2.6, 2.7; hardware-facts 1.3, 1.7).
//!
//! The state nibble and the error/ID flags of AL control and AL status are the EtherCAT
//! state machine's (ETG.1000.6 6.4), which every ESC only stores: they are defined once, in
//! the application-layer core ([`coe_core::esm`]), and read here. The register addresses
//! and the event bits are the ESC's and stay in this crate.

use coe_core::esm::{AlState, ERROR_FLAG, ID_FLAG, STATE_MASK};

/// AL event request bits (0x0220..0x0222) as shifted out on MISO during the address phase
/// of every SPI access (ESC-II 2.7.4; hardware-facts 1.3).
///
/// With 2-byte SPI addressing only 0x0220/0x0221 are shifted out, so bits 16..23
/// (SyncManagers 8..15) read as 0; the ET1100 has 8 SyncManagers, so nothing is lost.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AlEvents(u32);

impl AlEvents {
    /// b0: AL control written by the master; cleared by reading 0x0120/0x0121.
    pub const AL_CONTROL: u32 = 1 << 0;
    /// b1: DC latch event; cleared by reading the latch status/time.
    pub const DC_LATCH: u32 = 1 << 1;
    /// b2: SYNC0 (if mapped with 0x0151 b3); cleared by reading 0x098E.
    pub const SYNC0: u32 = 1 << 2;
    /// b3: SYNC1 (if mapped with 0x0151 b7); cleared by reading 0x098F.
    pub const SYNC1: u32 = 1 << 3;
    /// b4: SyncManager activation register changed; cleared by reading 0x0806+8n.
    pub const SM_ACTIVATION: u32 = 1 << 4;
    /// b5: EEPROM emulation command pending.
    pub const EEPROM_EMULATION: u32 = 1 << 5;
    /// b6: process-data watchdog expired; cleared by reading 0x0440.
    pub const WATCHDOG: u32 = 1 << 6;

    /// The mask of SyncManager `n`'s interrupt bit (8 + n); 0 for `n >= 16`.
    pub const fn sm_mask(n: u8) -> u32 {
        if n < 16 {
            1 << (8 + n as u32)
        } else {
            0
        }
    }

    /// Wraps raw event bits.
    pub const fn from_bits(bits: u32) -> Self {
        Self(bits)
    }

    /// Builds the events from the little-endian MISO bytes of the address phase
    /// (0x0220, 0x0221 and, with 3-byte addressing, 0x0222).
    pub const fn from_le_bytes(b: [u8; 4]) -> Self {
        Self(u32::from_le_bytes(b))
    }

    /// The raw bits (the layout of 0x0220).
    pub const fn bits(self) -> u32 {
        self.0
    }

    /// No event set.
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// All bits of a non-empty `mask` set (false for an empty mask).
    pub const fn contains(self, mask: u32) -> bool {
        self.0 & mask == mask && mask != 0
    }

    /// b0: AL control written.
    pub const fn al_control(self) -> bool {
        self.contains(Self::AL_CONTROL)
    }

    /// b1: DC latch event.
    pub const fn dc_latch(self) -> bool {
        self.contains(Self::DC_LATCH)
    }

    /// b2: SYNC0.
    pub const fn sync0(self) -> bool {
        self.contains(Self::SYNC0)
    }

    /// b3: SYNC1.
    pub const fn sync1(self) -> bool {
        self.contains(Self::SYNC1)
    }

    /// b4: SyncManager activation changed.
    pub const fn sm_activation(self) -> bool {
        self.contains(Self::SM_ACTIVATION)
    }

    /// b5: EEPROM emulation command.
    pub const fn eeprom_emulation(self) -> bool {
        self.contains(Self::EEPROM_EMULATION)
    }

    /// b6: process-data watchdog expired.
    pub const fn watchdog(self) -> bool {
        self.contains(Self::WATCHDOG)
    }

    /// b(8+n): SyncManager `n` interrupt (false for `n >= 16`).
    pub const fn sm(self, n: u8) -> bool {
        self.contains(Self::sm_mask(n))
    }
}

impl From<AlEvents> for u32 {
    fn from(e: AlEvents) -> Self {
        e.0
    }
}

impl From<u32> for AlEvents {
    fn from(bits: u32) -> Self {
        Self(bits)
    }
}

/// AL control (0x0120, u16), written by the master (ESC-II 2.6.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AlControl(pub u16);

impl AlControl {
    /// Bits 3:0: the raw requested state.
    pub const fn state_bits(self) -> u8 {
        (self.0 & STATE_MASK) as u8
    }

    /// The requested state; `None` for a nibble that names no state (AL status code 0x0012).
    pub const fn state(self) -> Option<AlState> {
        AlState::from_nibble(self.state_bits())
    }

    /// b4: error acknowledge.
    pub const fn error_ack(self) -> bool {
        self.0 & ERROR_FLAG != 0
    }

    /// b5: device identification request.
    pub const fn id_request(self) -> bool {
        self.0 & ID_FLAG != 0
    }
}

/// AL status (0x0130, u16), written by the PDI (ESC-II 2.6.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AlStatus(pub u16);

impl AlStatus {
    /// Builds a status from a state, the error flag (b4) and the ID-loaded flag (b5).
    pub const fn new(state: AlState, error: bool, id_loaded: bool) -> Self {
        let mut v = state.nibble() as u16;
        if error {
            v |= ERROR_FLAG;
        }
        if id_loaded {
            v |= ID_FLAG;
        }
        Self(v)
    }

    /// Bits 3:0: the raw state.
    pub const fn state_bits(self) -> u8 {
        (self.0 & STATE_MASK) as u8
    }

    /// The state; `None` for a nibble that names no state.
    pub const fn state(self) -> Option<AlState> {
        AlState::from_nibble(self.state_bits())
    }

    /// b4: error flag.
    pub const fn error(self) -> bool {
        self.0 & ERROR_FLAG != 0
    }

    /// b5: device identification loaded.
    pub const fn id_loaded(self) -> bool {
        self.0 & ID_FLAG != 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn events() {
        let e = AlEvents::from_le_bytes([0x51, 0x02, 0x00, 0x00]);
        assert!(e.al_control() && e.sm_activation() && e.watchdog() && e.sm(1));
        assert!(!e.sync0() && !e.sm(0) && !e.sm(16) && !e.dc_latch());
        assert_eq!(AlEvents::sm_mask(16), 0);
        assert!(!AlEvents::default().contains(0));
    }

    #[test]
    fn states_and_flags() {
        let s = AlStatus::new(AlState::SafeOp, true, false);
        assert_eq!(s.0, 0x14);
        assert!(s.error() && !s.id_loaded() && s.state() == Some(AlState::SafeOp));
        assert_eq!(AlStatus::new(AlState::Bootstrap, false, true).0, 0x23);
        let c = AlControl(0x0022);
        assert_eq!(c.state(), Some(AlState::PreOp));
        assert!(c.id_request() && !c.error_ack());
        // A nibble that names no state survives as its bits.
        let c = AlControl(0x0015);
        assert_eq!((c.state(), c.state_bits()), (None, 5));
        assert!(c.error_ack());
    }
}
