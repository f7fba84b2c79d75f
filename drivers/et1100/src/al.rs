//! Application layer registers: AL event request (0x0220), AL control (0x0120),
//! AL status (0x0130) (ESC-II 2.6, 2.7; hardware-facts 1.3, 1.7).
//!
//! The state nibble and the error/ID flags of AL control and AL status are the EtherCAT
//! state machine's (ETG.1000.6 6.4), which every ESC only stores: they are defined once, in
//! the application-layer core ([`coe_core::esm`]), and read here. The register addresses
//! and the event bits are the ESC's and stay in this crate.

use coe_core::esm::{AlState, ERROR_FLAG, ID_FLAG, STATE_MASK};

bitflags::bitflags! {
    /// AL event request bits (0x0220..0x0222) as shifted out on MISO during the address
    /// phase of every SPI access (ESC-II 2.7.4; hardware-facts 1.3).
    ///
    /// With 2-byte SPI addressing only 0x0220/0x0221 are shifted out, so bits 16..23
    /// (SyncManagers 8..15) read as 0; the ET1100 has 8 SyncManagers, so nothing is lost.
    /// Bits without a name (reserved) are kept as read.
    #[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
    pub struct AlEvents: u32 {
        /// b0: AL control written by the master; cleared by reading 0x0120/0x0121.
        const AL_CONTROL = 1 << 0;
        /// b1: DC latch event; cleared by reading the latch status/time.
        const DC_LATCH = 1 << 1;
        /// b2: SYNC0 (if mapped with 0x0151 b3); cleared by reading 0x098E.
        const SYNC0 = 1 << 2;
        /// b3: SYNC1 (if mapped with 0x0151 b7); cleared by reading 0x098F.
        const SYNC1 = 1 << 3;
        /// b4: SyncManager activation register changed; cleared by reading 0x0806+8n.
        const SM_ACTIVATION = 1 << 4;
        /// b5: EEPROM emulation command pending.
        const EEPROM_EMULATION = 1 << 5;
        /// b6: process-data watchdog expired; cleared by reading 0x0440.
        const WATCHDOG = 1 << 6;
        /// b8: SyncManager 0 interrupt (see [`AlEvents::sm`] for the others).
        const SM0 = 1 << 8;
        /// b9: SyncManager 1 interrupt.
        const SM1 = 1 << 9;
        /// b10: SyncManager 2 interrupt.
        const SM2 = 1 << 10;
        /// b11: SyncManager 3 interrupt.
        const SM3 = 1 << 11;
        /// Reserved and further SyncManager bits: kept as read.
        const _ = !0;
    }
}

impl AlEvents {
    /// AL event bits 0..15 (AL control .. SyncManager 7): what a 2-byte SPI address phase
    /// shifts out.
    pub const LOW: Self = Self::from_bits_retain(0xFFFF);

    /// The interrupt bit of SyncManager `n` (b8 + n); empty for `n >= 16`.
    pub const fn sm(n: u8) -> Self {
        if n < 16 {
            Self::from_bits_retain(1 << (8 + n as u32))
        } else {
            Self::empty()
        }
    }

    /// Builds the events from the little-endian MISO bytes of the address phase
    /// (0x0220, 0x0221 and, with 3-byte addressing, 0x0222).
    pub const fn from_le_bytes(b: [u8; 4]) -> Self {
        Self::from_bits_retain(u32::from_le_bytes(b))
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for AlEvents {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(f, "AlEvents({=u32:#x})", self.bits())
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
        assert!(e.contains(AlEvents::AL_CONTROL | AlEvents::SM_ACTIVATION | AlEvents::WATCHDOG));
        assert!(e.contains(AlEvents::SM1) && e.intersects(AlEvents::sm(1)));
        assert!(!e.intersects(AlEvents::SYNC0 | AlEvents::SM0 | AlEvents::DC_LATCH));
        assert_eq!(AlEvents::sm(2), AlEvents::SM2);
        assert_eq!(AlEvents::sm(15).bits(), 1 << 23);
        assert!(AlEvents::sm(16).is_empty());
        // Reserved bits survive.
        assert_eq!(
            AlEvents::from_le_bytes([0x80, 0, 0, 0x01]).bits(),
            0x0100_0080
        );
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
