//! SDO abort codes (ETG.1000.6 table 41, CiA 301 table 22).

crate::open_enum! {
    /// SDO abort code (u32) sent in an SDO abort transfer or an SDO Information error.
    pub enum SdoAbortCode(u32) {
        /// Toggle bit not alternated.
        ToggleBitNotAlternated = 0x0503_0000,
        /// SDO protocol timed out.
        SdoProtocolTimeout = 0x0504_0000,
        /// Client/server command specifier not valid or unknown.
        InvalidCommandSpecifier = 0x0504_0001,
        /// Invalid block size (block mode only).
        InvalidBlockSize = 0x0504_0002,
        /// Invalid sequence number (block mode only).
        InvalidSequenceNumber = 0x0504_0003,
        /// CRC error (block mode only).
        CrcError = 0x0504_0004,
        /// Out of memory.
        OutOfMemory = 0x0504_0005,
        /// Unsupported access to an object.
        UnsupportedAccess = 0x0601_0000,
        /// Attempt to read a write-only object.
        ReadOfWriteOnly = 0x0601_0001,
        /// Attempt to write a read-only object.
        WriteOfReadOnly = 0x0601_0002,
        /// Subindex cannot be written, SI0 must be 0 for write access (complete access).
        SubindexZeroMustBeZero = 0x0601_0003,
        /// Complete access not supported for objects of variable length such as ENUM or strings.
        CompleteAccessVariableLength = 0x0601_0004,
        /// Object length exceeds mailbox size.
        LengthExceedsMailbox = 0x0601_0005,
        /// Object mapped to RxPDO, SDO download blocked.
        MappedToRxPdo = 0x0601_0006,
        /// The object does not exist in the object dictionary.
        ObjectDoesNotExist = 0x0602_0000,
        /// The object cannot be mapped into the PDO.
        CannotBeMapped = 0x0604_0041,
        /// The number and length of the objects to be mapped would exceed the PDO length.
        PdoLengthExceeded = 0x0604_0042,
        /// General parameter incompatibility reason.
        ParameterIncompatible = 0x0604_0043,
        /// General internal incompatibility in the device.
        InternalIncompatibility = 0x0604_0047,
        /// Access failed due to a hardware error.
        HardwareError = 0x0606_0000,
        /// Data type does not match, length of service parameter does not match.
        LengthMismatch = 0x0607_0010,
        /// Data type does not match, length of service parameter too high.
        LengthTooHigh = 0x0607_0012,
        /// Data type does not match, length of service parameter too low.
        LengthTooLow = 0x0607_0013,
        /// Subindex does not exist.
        SubindexDoesNotExist = 0x0609_0011,
        /// Value range of parameter exceeded (only for write access).
        ValueRangeExceeded = 0x0609_0030,
        /// Value of parameter written too high.
        ValueTooHigh = 0x0609_0031,
        /// Value of parameter written too low.
        ValueTooLow = 0x0609_0032,
        /// Configured module list does not match detected module list.
        ModuleListMismatch = 0x0609_0033,
        /// Maximum value is less than minimum value.
        MaxLessThanMin = 0x0609_0036,
        /// Resource not available: SDO connection.
        ResourceNotAvailable = 0x060A_0023,
        /// General error.
        GeneralError = 0x0800_0000,
        /// Data cannot be transferred or stored to the application.
        CannotStore = 0x0800_0020,
        /// Data cannot be transferred or stored because of local control.
        LocalControl = 0x0800_0021,
        /// Data cannot be transferred or stored because of the present device state.
        DeviceState = 0x0800_0022,
        /// Object dictionary dynamic generation failed or no object dictionary present.
        NoObjectDictionary = 0x0800_0023,
        /// No data available.
        NoDataAvailable = 0x0800_0024,
    }
}

#[cfg(test)]
mod tests {
    use super::SdoAbortCode;

    #[test]
    fn known_codes_round_trip() {
        for code in [
            0x0503_0000u32,
            0x0601_0003,
            0x0604_0041,
            0x0609_0031,
            0x0800_0024,
        ] {
            let named = SdoAbortCode::from(code);
            assert!(!matches!(named, SdoAbortCode::Unknown(_)), "{code:#x}");
            assert_eq!(u32::from(named), code);
        }
    }

    #[test]
    fn unknown_code_is_kept() {
        assert_eq!(
            SdoAbortCode::from(0x1234_5678),
            SdoAbortCode::Unknown(0x1234_5678)
        );
        assert_eq!(u32::from(SdoAbortCode::Unknown(0x1234_5678)), 0x1234_5678);
    }
}
