//! Object dictionary building blocks: data types, object codes, access rights.
//!
//! Codes from ETG.1000.6 table 64 (data types), table 63 (object codes) and the
//! SDO Information entry description (ETG.1000.6 5.6.3.6, "ObjectAccess").

use crate::esm::AlState;
use core::fmt;

crate::open_enum! {
    /// CoE data type index (ETG.1000.6 table 64; CiA 301 table 44).
    ///
    /// The value is the object index of the data type definition (0x0001..0x0037) that the
    /// SDO Information object and entry descriptions carry.
    pub enum DataType(u16) {
        /// BOOLEAN (1 bit in process data, 1 byte in SDO transfers).
        Boolean = 0x0001,
        /// INTEGER8.
        Integer8 = 0x0002,
        /// INTEGER16.
        Integer16 = 0x0003,
        /// INTEGER32.
        Integer32 = 0x0004,
        /// UNSIGNED8.
        Unsigned8 = 0x0005,
        /// UNSIGNED16.
        Unsigned16 = 0x0006,
        /// UNSIGNED32.
        Unsigned32 = 0x0007,
        /// REAL32 (IEEE 754 single).
        Real32 = 0x0008,
        /// VISIBLE_STRING (ISO 646 characters, no terminating NUL required).
        VisibleString = 0x0009,
        /// OCTET_STRING.
        OctetString = 0x000A,
        /// UNICODE_STRING (UTF-16 code units).
        UnicodeString = 0x000B,
        /// TIME_OF_DAY (48 bit).
        TimeOfDay = 0x000C,
        /// TIME_DIFFERENCE (48 bit).
        TimeDifference = 0x000D,
        /// DOMAIN (application-specific block of bytes).
        Domain = 0x000F,
        /// INTEGER24.
        Integer24 = 0x0010,
        /// REAL64 (IEEE 754 double).
        Real64 = 0x0011,
        /// INTEGER64.
        Integer64 = 0x0015,
        /// UNSIGNED24.
        Unsigned24 = 0x0016,
        /// UNSIGNED64.
        Unsigned64 = 0x001B,
        /// PDO_MAPPING record type (0x16xx/0x1Axx objects).
        PdoMapping = 0x0021,
        /// IDENTITY record type (0x1018).
        Identity = 0x0023,
        /// BIT1.
        Bit1 = 0x0030,
        /// BIT2.
        Bit2 = 0x0031,
        /// BIT3.
        Bit3 = 0x0032,
        /// BIT4.
        Bit4 = 0x0033,
        /// BIT5.
        Bit5 = 0x0034,
        /// BIT6.
        Bit6 = 0x0035,
        /// BIT7.
        Bit7 = 0x0036,
        /// BIT8.
        Bit8 = 0x0037,
    }
}

impl DataType {
    /// The 16-bit code (a `const` version of `u16::from`).
    pub const fn code(self) -> u16 {
        match self {
            Self::Boolean => 0x0001,
            Self::Integer8 => 0x0002,
            Self::Integer16 => 0x0003,
            Self::Integer32 => 0x0004,
            Self::Unsigned8 => 0x0005,
            Self::Unsigned16 => 0x0006,
            Self::Unsigned32 => 0x0007,
            Self::Real32 => 0x0008,
            Self::VisibleString => 0x0009,
            Self::OctetString => 0x000A,
            Self::UnicodeString => 0x000B,
            Self::TimeOfDay => 0x000C,
            Self::TimeDifference => 0x000D,
            Self::Domain => 0x000F,
            Self::Integer24 => 0x0010,
            Self::Real64 => 0x0011,
            Self::Integer64 => 0x0015,
            Self::Unsigned24 => 0x0016,
            Self::Unsigned64 => 0x001B,
            Self::PdoMapping => 0x0021,
            Self::Identity => 0x0023,
            Self::Bit1 => 0x0030,
            Self::Bit2 => 0x0031,
            Self::Bit3 => 0x0032,
            Self::Bit4 => 0x0033,
            Self::Bit5 => 0x0034,
            Self::Bit6 => 0x0035,
            Self::Bit7 => 0x0036,
            Self::Bit8 => 0x0037,
            Self::Unknown(code) => code,
        }
    }

    /// Bit length of a fixed-size type; `None` for strings, DOMAIN, record types and unknown codes.
    pub const fn bit_len(self) -> Option<u16> {
        Some(match self {
            Self::Boolean | Self::Bit1 => 1,
            Self::Bit2 => 2,
            Self::Bit3 => 3,
            Self::Bit4 => 4,
            Self::Bit5 => 5,
            Self::Bit6 => 6,
            Self::Bit7 => 7,
            Self::Integer8 | Self::Unsigned8 | Self::Bit8 => 8,
            Self::Integer16 | Self::Unsigned16 => 16,
            Self::Integer24 | Self::Unsigned24 => 24,
            Self::Integer32 | Self::Unsigned32 | Self::Real32 => 32,
            Self::TimeOfDay | Self::TimeDifference => 48,
            Self::Integer64 | Self::Unsigned64 | Self::Real64 => 64,
            _ => return None,
        })
    }

    /// True for the variable-length types (strings, DOMAIN) whose length the entry gives.
    pub const fn is_variable_length(self) -> bool {
        matches!(
            self,
            Self::VisibleString | Self::OctetString | Self::UnicodeString | Self::Domain
        )
    }

    /// True for signed integer types (two's complement).
    pub const fn is_signed(self) -> bool {
        matches!(
            self,
            Self::Integer8 | Self::Integer16 | Self::Integer24 | Self::Integer32 | Self::Integer64
        )
    }

    /// True for the integer-like types whose value is a (signed or unsigned) number:
    /// BOOLEAN, INTEGERn, UNSIGNEDn and BITn.
    pub const fn is_integer(self) -> bool {
        matches!(
            self,
            Self::Boolean
                | Self::Integer8
                | Self::Integer16
                | Self::Integer24
                | Self::Integer32
                | Self::Integer64
                | Self::Unsigned8
                | Self::Unsigned16
                | Self::Unsigned24
                | Self::Unsigned32
                | Self::Unsigned64
                | Self::Bit1
                | Self::Bit2
                | Self::Bit3
                | Self::Bit4
                | Self::Bit5
                | Self::Bit6
                | Self::Bit7
                | Self::Bit8
        )
    }

    /// True if an entry of this type may be mapped into a PDO (fixed-size basic types only).
    pub const fn is_pdo_mappable(self) -> bool {
        self.is_integer() || matches!(self, Self::Real32 | Self::Real64)
    }

    /// Number of bytes an SDO transfer of this type carries (`ceil(bits / 8)`, BOOLEAN and
    /// BITn take one byte); `None` for variable-length and record types.
    pub const fn sdo_size(self) -> Option<usize> {
        match self.bit_len() {
            Some(bits) => Some((bits as usize).div_ceil(8)),
            None => None,
        }
    }

    /// The ESI (ETG.2000) type name, e.g. `UINT`, `STRING(8)`, `ARRAY [0..3] OF BYTE`.
    ///
    /// `bit_len` is the entry's bit length; it sizes the string and array forms.
    pub const fn esi_name(self, bit_len: u16) -> EsiTypeName {
        let bytes = bit_len.div_ceil(8);
        match self {
            Self::Boolean => EsiTypeName::Plain("BOOL"),
            Self::Integer8 => EsiTypeName::Plain("SINT"),
            Self::Integer16 => EsiTypeName::Plain("INT"),
            Self::Integer24 => EsiTypeName::Plain("INT24"),
            Self::Integer32 => EsiTypeName::Plain("DINT"),
            Self::Integer64 => EsiTypeName::Plain("LINT"),
            Self::Unsigned8 => EsiTypeName::Plain("USINT"),
            Self::Unsigned16 => EsiTypeName::Plain("UINT"),
            Self::Unsigned24 => EsiTypeName::Plain("UINT24"),
            Self::Unsigned32 => EsiTypeName::Plain("UDINT"),
            Self::Unsigned64 => EsiTypeName::Plain("ULINT"),
            Self::Real32 => EsiTypeName::Plain("REAL"),
            Self::Real64 => EsiTypeName::Plain("LREAL"),
            Self::TimeOfDay => EsiTypeName::Plain("TIME_OF_DAY"),
            Self::TimeDifference => EsiTypeName::Plain("TIME_DIFFERENCE"),
            Self::Domain => EsiTypeName::Plain("DOMAIN"),
            Self::PdoMapping => EsiTypeName::Plain("PDO_MAPPING"),
            Self::Identity => EsiTypeName::Plain("IDENTITY"),
            Self::Bit1 => EsiTypeName::Plain("BIT1"),
            Self::Bit2 => EsiTypeName::Plain("BIT2"),
            Self::Bit3 => EsiTypeName::Plain("BIT3"),
            Self::Bit4 => EsiTypeName::Plain("BIT4"),
            Self::Bit5 => EsiTypeName::Plain("BIT5"),
            Self::Bit6 => EsiTypeName::Plain("BIT6"),
            Self::Bit7 => EsiTypeName::Plain("BIT7"),
            Self::Bit8 => EsiTypeName::Plain("BIT8"),
            Self::VisibleString => EsiTypeName::String(bytes),
            Self::UnicodeString => EsiTypeName::UnicodeString(bytes / 2),
            Self::OctetString => EsiTypeName::ByteArray(bytes),
            Self::Unknown(_) => EsiTypeName::Plain("UNKNOWN"),
        }
    }
}

/// An ESI type name; `Display` writes it as ESI files spell it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EsiTypeName {
    /// A fixed name such as `UINT`.
    Plain(&'static str),
    /// `STRING(n)`, n characters.
    String(u16),
    /// `UNICODE_STRING(n)`, n UTF-16 code units.
    UnicodeString(u16),
    /// `ARRAY [0..n-1] OF BYTE` (OCTET_STRING of n bytes).
    ByteArray(u16),
}

impl fmt::Display for EsiTypeName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::Plain(name) => f.write_str(name),
            Self::String(n) => write!(f, "STRING({n})"),
            Self::UnicodeString(n) => write!(f, "UNICODE_STRING({n})"),
            Self::ByteArray(0) => f.write_str("ARRAY [0..0] OF BYTE"),
            Self::ByteArray(n) => write!(f, "ARRAY [0..{}] OF BYTE", n - 1),
        }
    }
}

/// Object code (ETG.1000.6 table 63; the `objCode` byte of the SDO Information object
/// description).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ObjectCode {
    /// VAR (7): a single value at subindex 0.
    Var = 7,
    /// ARRAY (8): sub 0 = number of entries, subs 1..n of one type.
    Array = 8,
    /// RECORD (9): sub 0 = highest subindex, entries of different types.
    Record = 9,
}

impl ObjectCode {
    /// The code byte.
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// Decodes the code byte.
    pub const fn from_code(code: u8) -> Option<Self> {
        match code {
            7 => Some(Self::Var),
            8 => Some(Self::Array),
            9 => Some(Self::Record),
            _ => None,
        }
    }

    /// The ESI/ETG spelling (`VAR`, `ARRAY`, `RECORD`).
    pub const fn name(self) -> &'static str {
        match self {
            Self::Var => "VAR",
            Self::Array => "ARRAY",
            Self::Record => "RECORD",
        }
    }
}

/// Entry access rights and flags with the exact bit layout of the SDO Information entry
/// description "ObjectAccess" word (ETG.1000.6 5.6.3.6, table 58):
///
/// | bit | meaning |
/// |---|---|
/// | 0, 1, 2 | readable in PREOP, SAFEOP, OP |
/// | 3, 4, 5 | writable in PREOP, SAFEOP, OP |
/// | 6 | mappable in an RxPDO (output) |
/// | 7 | mappable in a TxPDO (input) |
/// | 8 | backup: the entry is part of the backup |
/// | 9 | settings: the entry is a startup setting |
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Access(pub u16);

impl Access {
    /// Read in PREOP.
    pub const READ_PREOP: u16 = 1 << 0;
    /// Read in SAFEOP.
    pub const READ_SAFEOP: u16 = 1 << 1;
    /// Read in OP.
    pub const READ_OP: u16 = 1 << 2;
    /// Write in PREOP.
    pub const WRITE_PREOP: u16 = 1 << 3;
    /// Write in SAFEOP.
    pub const WRITE_SAFEOP: u16 = 1 << 4;
    /// Write in OP.
    pub const WRITE_OP: u16 = 1 << 5;
    /// Mappable into an RxPDO.
    pub const RXPDO: u16 = 1 << 6;
    /// Mappable into a TxPDO.
    pub const TXPDO: u16 = 1 << 7;
    /// Backup entry.
    pub const BACKUP: u16 = 1 << 8;
    /// Settings entry.
    pub const SETTINGS: u16 = 1 << 9;
    /// All read bits.
    pub const READ_ALL: u16 = 0x0007;
    /// All write bits.
    pub const WRITE_ALL: u16 = 0x0038;

    /// Read-only in PREOP, SAFEOP and OP.
    pub const RO: Self = Self(Self::READ_ALL);
    /// Write-only in PREOP, SAFEOP and OP.
    pub const WO: Self = Self(Self::WRITE_ALL);
    /// Read-write in PREOP, SAFEOP and OP.
    pub const RW: Self = Self(Self::READ_ALL | Self::WRITE_ALL);
    /// Readable always, writable in PREOP only (PDO mapping and assignment, sync parameters).
    pub const RW_PREOP: Self = Self(Self::READ_ALL | Self::WRITE_PREOP);
    /// Readable always, writable in PREOP and SAFEOP.
    pub const RW_PREOP_SAFEOP: Self = Self(Self::READ_ALL | Self::WRITE_PREOP | Self::WRITE_SAFEOP);
    /// Readable always, writable in PREOP and OP (ESI `WriteRestrictions="PreOP_OP"`).
    pub const RW_PREOP_OP: Self = Self(Self::READ_ALL | Self::WRITE_PREOP | Self::WRITE_OP);

    /// The raw word.
    pub const fn bits(self) -> u16 {
        self.0
    }

    /// Adds the RxPDO-mappable flag.
    pub const fn rx_mappable(self) -> Self {
        Self(self.0 | Self::RXPDO)
    }

    /// Adds the TxPDO-mappable flag.
    pub const fn tx_mappable(self) -> Self {
        Self(self.0 | Self::TXPDO)
    }

    /// Adds the backup flag.
    pub const fn backup(self) -> Self {
        Self(self.0 | Self::BACKUP)
    }

    /// Adds the settings flag.
    pub const fn settings(self) -> Self {
        Self(self.0 | Self::SETTINGS)
    }

    /// True if all bits of `mask` are set.
    pub const fn contains(self, mask: u16) -> bool {
        self.0 & mask == mask
    }

    /// True if any read bit is set.
    pub const fn is_readable(self) -> bool {
        self.0 & Self::READ_ALL != 0
    }

    /// True if any write bit is set.
    pub const fn is_writable(self) -> bool {
        self.0 & Self::WRITE_ALL != 0
    }

    /// True if mappable into an RxPDO.
    pub const fn is_rx_mappable(self) -> bool {
        self.0 & Self::RXPDO != 0
    }

    /// True if mappable into a TxPDO.
    pub const fn is_tx_mappable(self) -> bool {
        self.0 & Self::TXPDO != 0
    }

    /// True if the entry may be read by SDO in `state` (never in INIT or BOOT: no CoE there).
    pub const fn readable_in(self, state: AlState) -> bool {
        match state {
            AlState::PreOp => self.0 & Self::READ_PREOP != 0,
            AlState::SafeOp => self.0 & Self::READ_SAFEOP != 0,
            AlState::Op => self.0 & Self::READ_OP != 0,
            AlState::Init | AlState::Bootstrap => false,
        }
    }

    /// True if the entry may be written by SDO in `state` (never in INIT or BOOT).
    pub const fn writable_in(self, state: AlState) -> bool {
        match state {
            AlState::PreOp => self.0 & Self::WRITE_PREOP != 0,
            AlState::SafeOp => self.0 & Self::WRITE_SAFEOP != 0,
            AlState::Op => self.0 & Self::WRITE_OP != 0,
            AlState::Init | AlState::Bootstrap => false,
        }
    }

    /// ESI `<Access>` text: `ro`, `wo` or `rw` (`ro` also for an entry with no rights).
    pub const fn esi_access(self) -> &'static str {
        match (self.is_readable(), self.is_writable()) {
            (true, true) => "rw",
            (false, true) => "wo",
            _ => "ro",
        }
    }

    /// ESI `WriteRestrictions` attribute (`PreOP`, `PreOP_SafeOP`, `PreOP_OP`, `SafeOP`,
    /// `SafeOP_OP`, `OP`), `None` when writable in all three states or not at all.
    pub const fn esi_write_restrictions(self) -> Option<&'static str> {
        Self::esi_restriction((self.0 >> 3) & 0x7)
    }

    /// ESI `ReadRestrictions` attribute, `None` when readable in all three states or never.
    pub const fn esi_read_restrictions(self) -> Option<&'static str> {
        Self::esi_restriction(self.0 & 0x7)
    }

    const fn esi_restriction(bits: u16) -> Option<&'static str> {
        match bits {
            0b001 => Some("PreOP"),
            0b011 => Some("PreOP_SafeOP"),
            0b101 => Some("PreOP_OP"),
            0b010 => Some("SafeOP"),
            0b110 => Some("SafeOP_OP"),
            0b100 => Some("OP"),
            _ => None,
        }
    }

    /// ESI `<PdoMapping>` text: `R`, `T`, `RT` or `None` if not mappable.
    pub const fn esi_pdo_mapping(self) -> Option<&'static str> {
        match (self.is_rx_mappable(), self.is_tx_mappable()) {
            (true, true) => Some("RT"),
            (true, false) => Some("R"),
            (false, true) => Some("T"),
            (false, false) => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::format;

    #[test]
    fn data_type_codes_round_trip() {
        for code in [
            0x01u16, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0x08, 0x09, 0x0A, 0x0B, 0x0C, 0x0D, 0x0F,
            0x10, 0x11, 0x15, 0x16, 0x1B, 0x21, 0x23, 0x30, 0x31, 0x32, 0x33, 0x34, 0x35, 0x36,
            0x37,
        ] {
            let t = DataType::from(code);
            assert!(!matches!(t, DataType::Unknown(_)), "{code:#x}");
            assert_eq!(t.code(), code);
            assert_eq!(u16::from(t), code);
        }
        assert_eq!(DataType::from(0x0E).code(), 0x0E);
    }

    #[test]
    fn bit_lengths() {
        assert_eq!(DataType::Boolean.bit_len(), Some(1));
        assert_eq!(DataType::Bit3.bit_len(), Some(3));
        assert_eq!(DataType::Integer16.bit_len(), Some(16));
        assert_eq!(DataType::Unsigned24.bit_len(), Some(24));
        assert_eq!(DataType::Real64.bit_len(), Some(64));
        assert_eq!(DataType::VisibleString.bit_len(), None);
        assert_eq!(DataType::Boolean.sdo_size(), Some(1));
        assert_eq!(DataType::Unsigned24.sdo_size(), Some(3));
    }

    #[test]
    fn esi_names() {
        assert_eq!(format!("{}", DataType::Unsigned16.esi_name(16)), "UINT");
        assert_eq!(format!("{}", DataType::Integer16.esi_name(16)), "INT");
        assert_eq!(format!("{}", DataType::Unsigned32.esi_name(32)), "UDINT");
        assert_eq!(
            format!("{}", DataType::VisibleString.esi_name(24)),
            "STRING(3)"
        );
        assert_eq!(
            format!("{}", DataType::OctetString.esi_name(32)),
            "ARRAY [0..3] OF BYTE"
        );
    }

    #[test]
    fn access_bits_match_entry_description_layout() {
        assert_eq!(Access::RO.bits(), 0x0007);
        assert_eq!(Access::RW.bits(), 0x003F);
        assert_eq!(Access::WO.bits(), 0x0038);
        assert_eq!(Access::RW_PREOP.bits(), 0x000F);
        assert_eq!(Access::RO.tx_mappable().bits(), 0x0087);
        assert_eq!(Access::RW.rx_mappable().bits(), 0x007F);
        assert_eq!(Access::RW.backup().settings().bits(), 0x033F);
    }

    #[test]
    fn access_per_state() {
        let a = Access::RW_PREOP;
        assert!(a.readable_in(AlState::Op));
        assert!(a.writable_in(AlState::PreOp));
        assert!(!a.writable_in(AlState::SafeOp));
        assert!(!a.writable_in(AlState::Op));
        assert!(!Access::RW.readable_in(AlState::Init));
        assert!(!Access::RW.writable_in(AlState::Bootstrap));
        assert_eq!(a.esi_write_restrictions(), Some("PreOP"));
        assert_eq!(Access::RW.esi_write_restrictions(), None);
        assert_eq!(Access::WO.esi_access(), "wo");
        assert_eq!(Access::RO.tx_mappable().esi_pdo_mapping(), Some("T"));
    }
}
