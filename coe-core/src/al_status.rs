//! AL status codes (register 0x0134): the AL status code list of ETG.1000.6 (also ETG.1020
//! and the ESC datasheet section II, 0x0134; values cross-checked with SOES `esc.h` and SOEM
//! `ec_print.c`).

crate::open_enum! {
    /// AL status code (u16) the slave writes to 0x0134 together with the error flag of the
    /// AL status (0x0130 bit 4).
    pub enum AlStatusCode(u16) {
        /// No error.
        NoError = 0x0000,
        /// Unspecified error.
        Unspecified = 0x0001,
        /// No memory.
        NoMemory = 0x0002,
        /// Invalid requested state change.
        InvalidRequestedStateChange = 0x0011,
        /// Unknown requested state.
        UnknownRequestedState = 0x0012,
        /// Bootstrap not supported.
        BootstrapNotSupported = 0x0013,
        /// No valid firmware.
        NoValidFirmware = 0x0014,
        /// Invalid mailbox configuration (BOOT state).
        InvalidMailboxConfigurationBoot = 0x0015,
        /// Invalid mailbox configuration (PREOP state).
        InvalidMailboxConfiguration = 0x0016,
        /// Invalid sync manager configuration.
        InvalidSyncManagerConfiguration = 0x0017,
        /// No valid inputs available.
        NoValidInputs = 0x0018,
        /// No valid outputs.
        NoValidOutputs = 0x0019,
        /// Synchronization error.
        SynchronizationError = 0x001A,
        /// Sync manager watchdog.
        SyncManagerWatchdog = 0x001B,
        /// Invalid sync manager types.
        InvalidSyncManagerTypes = 0x001C,
        /// Invalid output configuration.
        InvalidOutputConfiguration = 0x001D,
        /// Invalid input configuration.
        InvalidInputConfiguration = 0x001E,
        /// Invalid watchdog configuration.
        InvalidWatchdogConfiguration = 0x001F,
        /// Slave needs cold start.
        NeedColdStart = 0x0020,
        /// Slave needs INIT.
        NeedInit = 0x0021,
        /// Slave needs PREOP.
        NeedPreOp = 0x0022,
        /// Slave needs SAFEOP.
        NeedSafeOp = 0x0023,
        /// Invalid input mapping.
        InvalidInputMapping = 0x0024,
        /// Invalid output mapping.
        InvalidOutputMapping = 0x0025,
        /// Inconsistent settings.
        InconsistentSettings = 0x0026,
        /// Free run not supported.
        FreeRunNotSupported = 0x0027,
        /// Synchronization mode not supported.
        SyncModeNotSupported = 0x0028,
        /// Free run needs 3-buffer mode.
        FreeRunNeeds3BufferMode = 0x0029,
        /// Background watchdog.
        BackgroundWatchdog = 0x002A,
        /// No valid inputs and outputs.
        NoValidInputsAndOutputs = 0x002B,
        /// Fatal sync error.
        FatalSyncError = 0x002C,
        /// No sync error (synchronization not received).
        NoSyncError = 0x002D,
        /// Invalid input FMMU configuration.
        InvalidInputFmmuConfiguration = 0x002E,
        /// Invalid DC SYNC configuration.
        InvalidDcSyncConfiguration = 0x0030,
        /// Invalid DC latch configuration.
        InvalidDcLatchConfiguration = 0x0031,
        /// PLL error.
        PllError = 0x0032,
        /// DC sync IO error.
        DcSyncIoError = 0x0033,
        /// DC sync timeout error.
        DcSyncTimeout = 0x0034,
        /// DC invalid sync cycle time.
        DcInvalidSyncCycleTime = 0x0035,
        /// DC SYNC0 cycle time.
        DcSync0CycleTime = 0x0036,
        /// DC SYNC1 cycle time.
        DcSync1CycleTime = 0x0037,
        /// Mailbox AoE error.
        MbxAoe = 0x0041,
        /// Mailbox EoE error.
        MbxEoe = 0x0042,
        /// Mailbox CoE error.
        MbxCoe = 0x0043,
        /// Mailbox FoE error.
        MbxFoe = 0x0044,
        /// Mailbox SoE error.
        MbxSoe = 0x0045,
        /// Mailbox VoE error.
        MbxVoe = 0x004F,
        /// EEPROM no access.
        EepromNoAccess = 0x0050,
        /// EEPROM error.
        EepromError = 0x0051,
        /// External hardware not ready.
        ExternalHardwareNotReady = 0x0052,
        /// Slave restarted locally.
        SlaveRestartedLocally = 0x0060,
        /// Device identification value updated.
        DeviceIdentificationUpdated = 0x0061,
        /// Detected module ident list does not match.
        ModuleIdentListMismatch = 0x0070,
        /// Supply voltage too low.
        SupplyVoltageTooLow = 0x0080,
        /// Supply voltage too high.
        SupplyVoltageTooHigh = 0x0081,
        /// Temperature too low.
        TemperatureTooLow = 0x0082,
        /// Temperature too high.
        TemperatureTooHigh = 0x0083,
        /// Application controller available.
        ApplicationControllerAvailable = 0x00F0,
    }
}

impl AlStatusCode {
    /// The raw register value.
    pub fn code(self) -> u16 {
        self.into()
    }

    /// True for 0x8000..=0xFFFF, the vendor-specific range.
    pub fn is_vendor_specific(self) -> bool {
        self.code() >= 0x8000
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every code of the ETG.1000.6 list as given in hardware-facts 1.6 (written out, not
    /// derived from the enum).
    static TABLE: [(u16, AlStatusCode); 62] = [
        (0x0000, AlStatusCode::NoError),
        (0x0001, AlStatusCode::Unspecified),
        (0x0002, AlStatusCode::NoMemory),
        (0x0011, AlStatusCode::InvalidRequestedStateChange),
        (0x0012, AlStatusCode::UnknownRequestedState),
        (0x0013, AlStatusCode::BootstrapNotSupported),
        (0x0014, AlStatusCode::NoValidFirmware),
        (0x0015, AlStatusCode::InvalidMailboxConfigurationBoot),
        (0x0016, AlStatusCode::InvalidMailboxConfiguration),
        (0x0017, AlStatusCode::InvalidSyncManagerConfiguration),
        (0x0018, AlStatusCode::NoValidInputs),
        (0x0019, AlStatusCode::NoValidOutputs),
        (0x001A, AlStatusCode::SynchronizationError),
        (0x001B, AlStatusCode::SyncManagerWatchdog),
        (0x001C, AlStatusCode::InvalidSyncManagerTypes),
        (0x001D, AlStatusCode::InvalidOutputConfiguration),
        (0x001E, AlStatusCode::InvalidInputConfiguration),
        (0x001F, AlStatusCode::InvalidWatchdogConfiguration),
        (0x0020, AlStatusCode::NeedColdStart),
        (0x0021, AlStatusCode::NeedInit),
        (0x0022, AlStatusCode::NeedPreOp),
        (0x0023, AlStatusCode::NeedSafeOp),
        (0x0024, AlStatusCode::InvalidInputMapping),
        (0x0025, AlStatusCode::InvalidOutputMapping),
        (0x0026, AlStatusCode::InconsistentSettings),
        (0x0027, AlStatusCode::FreeRunNotSupported),
        (0x0028, AlStatusCode::SyncModeNotSupported),
        (0x0029, AlStatusCode::FreeRunNeeds3BufferMode),
        (0x002A, AlStatusCode::BackgroundWatchdog),
        (0x002B, AlStatusCode::NoValidInputsAndOutputs),
        (0x002C, AlStatusCode::FatalSyncError),
        (0x002D, AlStatusCode::NoSyncError),
        (0x002E, AlStatusCode::InvalidInputFmmuConfiguration),
        (0x0030, AlStatusCode::InvalidDcSyncConfiguration),
        (0x0031, AlStatusCode::InvalidDcLatchConfiguration),
        (0x0032, AlStatusCode::PllError),
        (0x0033, AlStatusCode::DcSyncIoError),
        (0x0034, AlStatusCode::DcSyncTimeout),
        (0x0035, AlStatusCode::DcInvalidSyncCycleTime),
        (0x0036, AlStatusCode::DcSync0CycleTime),
        (0x0037, AlStatusCode::DcSync1CycleTime),
        (0x0041, AlStatusCode::MbxAoe),
        (0x0042, AlStatusCode::MbxEoe),
        (0x0043, AlStatusCode::MbxCoe),
        (0x0044, AlStatusCode::MbxFoe),
        (0x0045, AlStatusCode::MbxSoe),
        (0x004F, AlStatusCode::MbxVoe),
        (0x0050, AlStatusCode::EepromNoAccess),
        (0x0051, AlStatusCode::EepromError),
        (0x0052, AlStatusCode::ExternalHardwareNotReady),
        (0x0060, AlStatusCode::SlaveRestartedLocally),
        (0x0061, AlStatusCode::DeviceIdentificationUpdated),
        (0x0070, AlStatusCode::ModuleIdentListMismatch),
        (0x0080, AlStatusCode::SupplyVoltageTooLow),
        (0x0081, AlStatusCode::SupplyVoltageTooHigh),
        (0x0082, AlStatusCode::TemperatureTooLow),
        (0x0083, AlStatusCode::TemperatureTooHigh),
        (0x00F0, AlStatusCode::ApplicationControllerAvailable),
        // Gaps in the table stay unknown and survive.
        (0x002F, AlStatusCode::Unknown(0x002F)),
        (0x0040, AlStatusCode::Unknown(0x0040)),
        (0x0003, AlStatusCode::Unknown(0x0003)),
        (0x8001, AlStatusCode::Unknown(0x8001)),
    ];

    #[test]
    fn every_code_both_ways() {
        for (raw, code) in TABLE {
            assert_eq!(AlStatusCode::from(raw), code, "{raw:#06x}");
            assert_eq!(code.code(), raw);
        }
    }

    #[test]
    fn codes_are_distinct() {
        for (i, (a, _)) in TABLE.iter().enumerate() {
            for (b, _) in TABLE.iter().skip(i + 1) {
                assert_ne!(a, b);
            }
        }
    }

    #[test]
    fn vendor_range() {
        assert!(AlStatusCode::Unknown(0x8001).is_vendor_specific());
        assert!(!AlStatusCode::SyncManagerWatchdog.is_vendor_specific());
    }
}
