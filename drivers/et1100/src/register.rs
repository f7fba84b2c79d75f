//! ESC register addresses (Beckhoff ESC datasheet section II, "Register description";
//! hardware-facts sections 1.1, 1.3-1.5).

/// Defines [`Register`] and [`Register::ALL`] from one list, so the list of every register
/// cannot miss one.
macro_rules! registers {
    ($($(#[$doc:meta])* $name:ident = $addr:expr,)*) => {
        /// An ESC register address as seen from the PDI.
        ///
        /// Indexed blocks (FMMU, SyncManager) have their first instance here; use
        /// [`Register::fmmu`] and [`Register::sync_manager`] for the others.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        #[repr(u16)]
        #[non_exhaustive]
        pub enum Register {
            $($(#[$doc])* $name = $addr,)*
        }

        impl Register {
            /// Every register, in address order.
            pub const ALL: &'static [Register] = &[$(Register::$name,)*];
        }
    };
}

registers! {
    /// ESC type (u8), ESC-II 2.1.1: 0x11 = ET1100, 0x12 = ET1200.
    Type = 0x0000,
    /// ESC revision (u8), ESC-II 2.1.2.
    Revision = 0x0001,
    /// ESC build (u16), ESC-II 2.1.3.
    Build = 0x0002,
    /// Number of FMMUs supported (u8), ESC-II 2.1.4.
    FmmusSupported = 0x0004,
    /// Number of SyncManagers supported (u8), ESC-II 2.1.5.
    SyncManagersSupported = 0x0005,
    /// Process RAM size in KiB (u8), ESC-II 2.1.6.
    RamSize = 0x0006,
    /// Configured station address (u16), ESC-II 2.2.1.
    StationAddress = 0x0010,
    /// Configured station alias (u16), ESC-II 2.2.2.
    StationAlias = 0x0012,
    /// DL status (u16), ESC-II 2.5.3: b0 PDI operational (EEPROM loaded), b1 PDI watchdog status.
    DlStatus = 0x0110,
    /// AL control (u16), ESC-II 2.6.1: \[3:0\] requested state, b4 error acknowledge,
    /// b5 ID request. Reading it from the PDI clears AL event bit 0.
    AlControl = 0x0120,
    /// AL status (u16), ESC-II 2.6.2: \[3:0\] state, b4 error, b5 ID loaded.
    AlStatus = 0x0130,
    /// AL status code (u16), ESC-II 2.6.3.
    AlStatusCode = 0x0134,
    /// PDI control (u8), ESC-II 2.6.5: 0x05 = SPI slave.
    PdiControl = 0x0140,
    /// ESC configuration (u8), ESC-II 2.6.6: b0 device emulation, b1 enhanced link detection,
    /// b2 DC SYNC unit, b3 DC latch unit.
    EscConfiguration = 0x0141,
    /// PDI configuration (u8), ESC-II 2.6.6.2: SPI mode, SPI_IRQ driver, SPI_SEL polarity,
    /// data-out sample mode.
    PdiConfiguration = 0x0150,
    /// SYNC/LATCH PDI configuration (u8): SYNC0/SYNC1 driver, output enable, map to AL event.
    SyncLatchConfiguration = 0x0151,
    /// AL event mask (u32), ESC-II 2.7.2; reset value 0x00FF_FF0F.
    AlEventMask = 0x0204,
    /// AL event request (u32), ESC-II 2.7.4: see [`AlEvents`](crate::AlEvents).
    AlEventRequest = 0x0220,
    /// PDI error counter (u8), ESC-II 2.8.4.
    PdiErrorCounter = 0x030D,
    /// PDI error code (u8), ESC-II 2.8.5.
    PdiErrorCode = 0x030E,
    /// Watchdog divider (u16), ESC-II 2.9.1: tick = (value + 2) x 40 ns.
    WatchdogDivider = 0x0400,
    /// PDI watchdog time (u16, ticks), ESC-II 2.9.2.
    WatchdogTimePdi = 0x0410,
    /// Process-data (SyncManager) watchdog time (u16, ticks), ESC-II 2.9.3.
    WatchdogTimeProcessData = 0x0420,
    /// Watchdog status process data (u16), ESC-II 2.9.4: b0 1 = OK, 0 = expired.
    /// Reading it clears AL event bit 6.
    WatchdogStatusProcessData = 0x0440,
    /// Watchdog counter process data (u8), ESC-II 2.9.5.
    WatchdogCounterProcessData = 0x0442,
    /// Watchdog counter PDI (u8), ESC-II 2.9.6.
    WatchdogCounterPdi = 0x0443,
    /// EEPROM configuration (u8), ESC-II 2.11.1: b0 offered to PDI, b1 force ECAT access.
    EepromConfiguration = 0x0500,
    /// EEPROM PDI access state (u8), ESC-II 2.11.2: b0 PDI accesses the EEPROM.
    EepromPdiAccess = 0x0501,
    /// EEPROM control/status (u16), ESC-II 2.11.3: see [`EepromStatus`](crate::EepromStatus).
    EepromControlStatus = 0x0502,
    /// EEPROM address in words (u32), ESC-II 2.11.4.
    EepromAddress = 0x0504,
    /// EEPROM data (4 or 8 bytes), ESC-II 2.11.5.
    EepromData = 0x0508,
    /// FMMU 0 (16 bytes each), ESC-II 2.13.
    Fmmu0 = 0x0600,
    /// SyncManager 0 (8 bytes each), ESC-II 2.14: see [`SyncManager`](crate::SyncManager).
    SyncManager0 = 0x0800,
    /// DC receive times (u32 per port), ESC-II 2.15.1.
    DcReceiveTimePort0 = 0x0900,
    /// DC system time (u64), ESC-II 2.15.2. Reading its first byte latches the whole value.
    DcSystemTime = 0x0910,
    /// DC cyclic unit control (u8), ESC-II 2.16.1: b0 SYNC unit assigned to PDI,
    /// b4/b5 latch units assigned to PDI.
    DcCyclicUnitControl = 0x0980,
    /// DC activation (u8), ESC-II 2.16.2: see [`SyncActivation`](crate::SyncActivation).
    DcActivation = 0x0981,
    /// DC SYNC pulse length (u16, 10 ns), ESC-II 2.16.3; 0 = acknowledge mode.
    DcPulseLength = 0x0982,
    /// DC activation status (u8), ESC-II 2.16.4.
    DcActivationStatus = 0x0984,
    /// SYNC0 status (u8), ESC-II 2.16.5: b0 SYNC0 triggered; reading it acknowledges.
    DcSync0Status = 0x098E,
    /// SYNC1 status (u8), ESC-II 2.16.6: b0 SYNC1 triggered; reading it acknowledges.
    DcSync1Status = 0x098F,
    /// DC start time cyclic operation (u64), ESC-II 2.16.7.
    DcStartTime = 0x0990,
    /// DC next SYNC1 pulse time (u64), ESC-II 2.16.8.
    DcNextSync1 = 0x0998,
    /// SYNC0 cycle time (u32, ns), ESC-II 2.16.9; 0 = single shot.
    DcSync0CycleTime = 0x09A0,
    /// SYNC1 cycle time (u32, ns), ESC-II 2.16.10: delay after SYNC0.
    DcSync1CycleTime = 0x09A4,
    /// Start of the process RAM.
    ProcessRam = 0x1000,
}

impl Register {
    /// Number of FMMU register blocks in the address map.
    pub const FMMU_COUNT: u8 = 16;
    /// Number of SyncManager register blocks in the address map.
    pub const SYNC_MANAGER_COUNT: u8 = 16;

    /// The register address.
    pub const fn addr(self) -> u16 {
        self as u16
    }

    /// The register at `addr` (the first byte of a register, or of the first FMMU or
    /// SyncManager block), if it is one of [`Register::ALL`].
    pub fn from_addr(addr: u16) -> Option<Self> {
        Self::ALL.iter().copied().find(|r| r.addr() == addr)
    }

    /// The address of FMMU `n` (16 bytes), or `None` for `n >= 16`.
    pub const fn fmmu(n: u8) -> Option<u16> {
        if n < Self::FMMU_COUNT {
            Some(Register::Fmmu0 as u16 + 16 * n as u16)
        } else {
            None
        }
    }

    /// The address of SyncManager `n` (8 bytes), or `None` for `n >= 16`.
    pub const fn sync_manager(n: u8) -> Option<u16> {
        if n < Self::SYNC_MANAGER_COUNT {
            Some(Register::SyncManager0 as u16 + 8 * n as u16)
        } else {
            None
        }
    }
}

impl From<Register> for u16 {
    fn from(r: Register) -> Self {
        r.addr()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn indexed_blocks() {
        assert_eq!(Register::sync_manager(0), Some(0x0800));
        assert_eq!(Register::sync_manager(3), Some(0x0818));
        assert_eq!(Register::sync_manager(15), Some(0x0878));
        assert_eq!(Register::sync_manager(16), None);
        assert_eq!(Register::fmmu(2), Some(0x0620));
        assert_eq!(Register::fmmu(16), None);
        assert_eq!(u16::from(Register::AlStatusCode), 0x0134);
    }

    #[test]
    fn all_registers_in_address_order() {
        assert!(Register::ALL.windows(2).all(|w| w[0].addr() < w[1].addr()));
        assert_eq!(Register::from_addr(0x0220), Some(Register::AlEventRequest));
        assert_eq!(Register::from_addr(0x0808), None);
        assert_eq!(Register::ALL.first(), Some(&Register::Type));
        assert_eq!(Register::ALL.last(), Some(&Register::ProcessRam));
    }
}
