//! The SII EEPROM image (ETG.1000.6 5.4, ETG.2010) generated from a [`DeviceDescription`]
//! into a caller's buffer, without allocation.
//!
//! Layout (16-bit words, little-endian):
//!
//! | Word | Content |
//! |---|---|
//! | 0x00..0x03 | PDI control/ESC configuration, PDI configuration/SYNC-LATCH, SYNC impulse length, extended PDI configuration |
//! | 0x04 | configured station alias |
//! | 0x07 | checksum: CRC-8 (poly 0x07, init 0xFF) over words 0..6 in the low byte |
//! | 0x08..0x0F | vendor ID, product code, revision, serial number (u32 each) |
//! | 0x14..0x17 | bootstrap mailbox out offset/size, in offset/size |
//! | 0x18..0x1B | standard mailbox out (SM0) offset/size, in (SM1) offset/size (0 without mailbox protocols) |
//! | 0x1C | mailbox protocols |
//! | 0x3E / 0x3F | EEPROM size (Kbit - 1) / version |
//! | 0x40.. | categories: type u16, length u16 in words, data; 0xFFFF ends the list |
//!
//! Categories written: Strings (10), General (30), FMMU (40), SyncM (41), TxPDO (50),
//! RxPDO (51), DC (60). With [`generate_with`], the oversampling part of the description
//! ([`Oversampling`]): a replicated PDO appears once (its base, as in Beckhoff's EL2262
//! EEPROM), and its op modes follow the plain ones in the DC category.

pub mod reader;

use crate::device::oversampling::Oversampling;
use crate::device::{DcOpMode, DescError, DeviceDescription, SmRole};
use crate::od::ObjectDesc;
use crate::pdo::{PdoDirection, PdoEntry};
use core::fmt;

/// Word addresses of the fixed area.
pub mod word {
    /// PDI control (0x0140) and ESC configuration (0x0141).
    pub const PDI_CONTROL: usize = 0x00;
    /// PDI configuration (0x0150) and SYNC/LATCH configuration (0x0151).
    pub const PDI_CONFIG: usize = 0x01;
    /// SYNC impulse length in 10 ns (0x0982).
    pub const SYNC_IMPULSE: usize = 0x02;
    /// Extended PDI configuration (0x0152).
    pub const PDI_CONFIG_2: usize = 0x03;
    /// Configured station alias (0x0012).
    pub const STATION_ALIAS: usize = 0x04;
    /// Checksum of words 0..6.
    pub const CHECKSUM: usize = 0x07;
    /// Vendor ID (u32).
    pub const VENDOR_ID: usize = 0x08;
    /// Product code (u32).
    pub const PRODUCT_CODE: usize = 0x0A;
    /// Revision number (u32).
    pub const REVISION: usize = 0x0C;
    /// Serial number (u32).
    pub const SERIAL_NUMBER: usize = 0x0E;
    /// Bootstrap receive mailbox offset, size, send mailbox offset, size.
    pub const BOOTSTRAP_MAILBOX: usize = 0x14;
    /// Standard receive (master -> slave) mailbox offset, size, send mailbox offset, size.
    pub const STANDARD_MAILBOX: usize = 0x18;
    /// Supported mailbox protocols.
    pub const MAILBOX_PROTOCOLS: usize = 0x1C;
    /// EEPROM size in Kbit minus one.
    pub const SIZE: usize = 0x3E;
    /// SII version.
    pub const VERSION: usize = 0x3F;
    /// First category header.
    pub const FIRST_CATEGORY: usize = 0x40;
}

/// Category types (ETG.1000.6 table 19).
pub mod category {
    /// Strings.
    pub const STRINGS: u16 = 10;
    /// Data types (not written).
    pub const DATA_TYPES: u16 = 20;
    /// General.
    pub const GENERAL: u16 = 30;
    /// FMMU usage.
    pub const FMMU: u16 = 40;
    /// SyncManagers.
    pub const SYNC_MANAGER: u16 = 41;
    /// TxPDOs (inputs).
    pub const TXPDO: u16 = 50;
    /// RxPDOs (outputs).
    pub const RXPDO: u16 = 51;
    /// Distributed clocks op modes.
    pub const DC: u16 = 60;
    /// End of the category list.
    pub const END: u16 = 0xFFFF;
}

/// Bytes of the General category (16 words).
pub const GENERAL_LEN: usize = 32;
/// Bytes of one SyncM category entry.
pub const SYNC_MANAGER_LEN: usize = 8;
/// Bytes of a PDO header in the TxPDO/RxPDO categories.
pub const PDO_HEADER_LEN: usize = 8;
/// Bytes of a PDO entry in the TxPDO/RxPDO categories.
pub const PDO_ENTRY_LEN: usize = 8;
/// Bytes of one DC category entry.
pub const DC_ENTRY_LEN: usize = 24;
/// SM number of a PDO that is not in the default assignment.
pub const PDO_NOT_ASSIGNED: u8 = 0xFF;
/// Most strings the Strings category can hold (its count is one byte).
pub const MAX_STRINGS: usize = 255;

/// The SII checksum's CRC: polynomial 0x07, initial value 0xFF, MSB first, no reflection,
/// no final XOR (ESC datasheet section II, "SII EEPROM" / ETG.1000.6 5.4). No catalogue of
/// the `crc` crate names these parameters, so they are given here.
const SII_CRC: crc::Algorithm<u8> = crc::Algorithm {
    width: 8,
    poly: 0x07,
    init: 0xFF,
    refin: false,
    refout: false,
    xorout: 0x00,
    check: 0xFB,
    residue: 0x00,
};

/// Bit by bit: the checksum covers 14 bytes, and no lookup table lands in a firmware that
/// reads SII images.
const SII_CRC8: crc::Crc<u8, crc::NoTable> = crc::Crc::<u8, crc::NoTable>::new(&SII_CRC);

/// CRC-8 of the SII checksum (word 7) over `data`: polynomial 0x07, initial value 0xFF, MSB
/// first, no reflection, no final XOR.
pub const fn crc8(data: &[u8]) -> u8 {
    SII_CRC8.checksum(data)
}

/// Why no image could be generated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SiiError {
    /// The description does not validate.
    Description(DescError),
    /// The output buffer is shorter than the image (`needed` bytes).
    BufferTooSmall {
        /// Bytes the image needs.
        needed: usize,
    },
    /// The image does not fit the EEPROM size of the description.
    EepromTooSmall {
        /// Bytes the image needs.
        needed: usize,
        /// The EEPROM size in bytes.
        size: u32,
    },
    /// More than [`MAX_STRINGS`] distinct strings.
    TooManyStrings,
    /// A string longer than 255 bytes (its length is one byte).
    StringTooLong {
        /// Its length.
        len: usize,
    },
    /// A PDO with more than 255 entries.
    TooManyPdoEntries {
        /// The PDO.
        index: u16,
    },
}

impl fmt::Display for SiiError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Description(e) => write!(f, "SII: {e}"),
            Self::BufferTooSmall { needed } => {
                write!(f, "SII: output buffer too small, {needed} bytes needed")
            }
            Self::EepromTooSmall { needed, size } => write!(
                f,
                "SII: image of {needed} bytes does not fit the {size}-byte EEPROM"
            ),
            Self::TooManyStrings => write!(f, "SII: more than {MAX_STRINGS} strings"),
            Self::StringTooLong { len } => {
                write!(f, "SII: string of {len} bytes, at most 255 allowed")
            }
            Self::TooManyPdoEntries { index } => {
                write!(f, "SII: PDO {index:#06X} has more than 255 entries")
            }
        }
    }
}

/// The Strings category: distinct strings in first-use order, indices from 1.
struct StringTable {
    list: [&'static str; MAX_STRINGS],
    len: usize,
}

impl StringTable {
    const fn new() -> Self {
        Self {
            list: [""; MAX_STRINGS],
            len: 0,
        }
    }

    /// The index of `s` (0 for an empty string), adding it if new.
    fn index(&mut self, s: &'static str) -> Result<u8, SiiError> {
        if s.is_empty() {
            return Ok(0);
        }
        if s.len() > 255 {
            return Err(SiiError::StringTooLong { len: s.len() });
        }
        let known = self.list.get(..self.len).unwrap_or(&[]);
        if let Some(i) = known.iter().position(|k| *k == s) {
            return Ok(i as u8 + 1);
        }
        let slot = self
            .list
            .get_mut(self.len)
            .ok_or(SiiError::TooManyStrings)?;
        *slot = s;
        self.len += 1;
        Ok(self.len as u8)
    }

    fn strings(&self) -> &[&'static str] {
        self.list.get(..self.len).unwrap_or(&[])
    }
}

/// Writes into the buffer while it lasts and counts past its end, so one pass both fills
/// the buffer and measures the image.
struct Writer<'a> {
    buf: &'a mut [u8],
    pos: usize,
}

impl Writer<'_> {
    fn bytes(&mut self, data: &[u8]) {
        for (i, b) in data.iter().enumerate() {
            if let Some(slot) = self.buf.get_mut(self.pos + i) {
                *slot = *b;
            }
        }
        self.pos += data.len();
    }

    fn u8(&mut self, v: u8) {
        self.bytes(&[v]);
    }

    fn u16(&mut self, v: u16) {
        self.bytes(&v.to_le_bytes());
    }

    fn u32(&mut self, v: u32) {
        self.bytes(&v.to_le_bytes());
    }

    fn zeros(&mut self, n: usize) {
        for _ in 0..n {
            self.u8(0);
        }
    }

    /// Writes a category header now and its length (in words) when `body` is done; pads the
    /// body to a whole word with `pad`.
    fn category(
        &mut self,
        kind: u16,
        pad: u8,
        body: impl FnOnce(&mut Self) -> Result<(), SiiError>,
    ) -> Result<(), SiiError> {
        self.u16(kind);
        let len_at = self.pos;
        self.u16(0);
        let start = self.pos;
        body(self)?;
        if (self.pos - start) % 2 != 0 {
            self.u8(pad);
        }
        let words = ((self.pos - start) / 2) as u16;
        for (i, b) in words.to_le_bytes().iter().enumerate() {
            if let Some(slot) = self.buf.get_mut(len_at + i) {
                *slot = *b;
            }
        }
        Ok(())
    }
}

/// Generates the SII image of `desc` into `out`; returns its length in bytes (the rest of
/// the EEPROM is the caller's, conventionally 0xFF). `out` may be empty to measure the image:
/// the error then is [`SiiError::BufferTooSmall`] with the size.
pub fn generate(desc: &DeviceDescription, out: &mut [u8]) -> Result<usize, SiiError> {
    generate_with(desc, &Oversampling::NONE, out)
}

/// [`generate`] with the oversampling part `os` of the description (validated with it).
pub fn generate_with(
    desc: &DeviceDescription,
    os: &Oversampling,
    out: &mut [u8],
) -> Result<usize, SiiError> {
    desc.validate().map_err(SiiError::Description)?;
    os.validate(desc).map_err(SiiError::Description)?;
    let listed = |o: &&ObjectDesc| os.is_listed(o.index);
    let op_modes = || {
        desc.dc
            .op_modes
            .iter()
            .chain(os.op_modes.iter().map(|m| &m.mode))
    };
    let mut strings = StringTable::new();
    // Collect every string first, in the order the categories use them.
    let names = &desc.names;
    let group = strings.index(names.group_type)?;
    let order = strings.index(names.order_code)?;
    let name = strings.index(names.device_name)?;
    for direction in [PdoDirection::Tx, PdoDirection::Rx] {
        for object in desc.pdo_objects(direction).filter(listed) {
            strings.index(object.name)?;
            for entry in desc.pdo_entries(object.index) {
                if let Some(e) = desc.mapped_entry(entry) {
                    strings.index(e.name)?;
                }
            }
        }
    }
    for mode in op_modes() {
        strings.index(mode.name)?;
        strings.index(mode.description)?;
    }

    let mut w = Writer { buf: out, pos: 0 };
    write_fixed_area(desc, &mut w);
    w.category(category::STRINGS, 0, |w| {
        w.u8(strings.strings().len() as u8);
        for s in strings.strings() {
            w.u8(s.len() as u8);
            w.bytes(s.as_bytes());
        }
        Ok(())
    })?;
    w.category(category::GENERAL, 0, |w| {
        write_general(desc, w, [group, 0, order, name]);
        Ok(())
    })?;
    w.category(category::FMMU, 0xFF, |w| {
        for usage in desc.fmmus {
            w.u8(usage.sii_code());
        }
        Ok(())
    })?;
    w.category(category::SYNC_MANAGER, 0, |w| {
        for sm in desc.sync_managers {
            w.u16(sm.start);
            w.u16(desc.default_sm_len(sm));
            w.u8(sm.control);
            w.u8(0);
            w.u8(u8::from(sm.enable));
            w.u8(sm.role.sii_type());
        }
        Ok(())
    })?;
    for (direction, kind) in [
        (PdoDirection::Tx, category::TXPDO),
        (PdoDirection::Rx, category::RXPDO),
    ] {
        if desc.pdo_objects(direction).any(|o| listed(&o)) {
            w.category(kind, 0, |w| {
                for object in desc.pdo_objects(direction).filter(listed) {
                    write_pdo(desc, w, &mut strings, object)?;
                }
                Ok(())
            })?;
        }
    }
    if op_modes().next().is_some() {
        w.category(category::DC, 0, |w| {
            for mode in op_modes() {
                write_op_mode(w, &mut strings, mode)?;
            }
            Ok(())
        })?;
    }
    w.u16(category::END);

    let needed = w.pos;
    if needed > desc.eeprom.size_bytes as usize {
        return Err(SiiError::EepromTooSmall {
            needed,
            size: desc.eeprom.size_bytes,
        });
    }
    if needed > w.buf.len() {
        return Err(SiiError::BufferTooSmall { needed });
    }
    Ok(needed)
}

/// The whole EEPROM content of `desc`: the image, then the rest of the EEPROM erased (0xFF)
/// up to [`EepromDesc::size_bytes`](crate::device::EepromDesc); returns that size. `out`
/// must hold the whole EEPROM.
pub fn generate_eeprom(desc: &DeviceDescription, out: &mut [u8]) -> Result<usize, SiiError> {
    generate_eeprom_with(desc, &Oversampling::NONE, out)
}

/// [`generate_eeprom`] with the oversampling part `os` of the description.
pub fn generate_eeprom_with(
    desc: &DeviceDescription,
    os: &Oversampling,
    out: &mut [u8],
) -> Result<usize, SiiError> {
    let size = desc.eeprom.size_bytes as usize;
    let Some(eeprom) = out.get_mut(..size) else {
        // Report a bad description or an image too large for the EEPROM first.
        return match generate_with(desc, os, &mut []) {
            Ok(_) | Err(SiiError::BufferTooSmall { .. }) => {
                Err(SiiError::BufferTooSmall { needed: size })
            }
            Err(e) => Err(e),
        };
    };
    let len = generate_with(desc, os, eeprom)?;
    if let Some(rest) = eeprom.get_mut(len..) {
        rest.fill(0xFF);
    }
    Ok(size)
}

/// One DC category entry (ETG.2010 table 14).
fn write_op_mode(
    w: &mut Writer<'_>,
    strings: &mut StringTable,
    mode: &DcOpMode,
) -> Result<(), SiiError> {
    w.u32(mode.cycle_time_sync0);
    w.u32(mode.shift_time_sync0);
    w.u32(mode.shift_time_sync1);
    w.u16(mode.sync1_factor as u16);
    w.u16(mode.assign_activate);
    w.u16(mode.sync0_factor as u16);
    w.u8(strings.index(mode.name)?);
    w.u8(strings.index(mode.description)?);
    w.zeros(4);
    Ok(())
}

fn write_fixed_area(desc: &DeviceDescription, w: &mut Writer<'_>) {
    let pdi = &desc.pdi;
    let config = [
        pdi.word0(),
        pdi.word1(),
        pdi.sync_pulse_10ns,
        pdi.extended,
        desc.eeprom.station_alias,
        0,
        0,
    ];
    let mut bytes = [0u8; 14];
    for (pair, word) in bytes.chunks_exact_mut(2).zip(config) {
        pair.copy_from_slice(&word.to_le_bytes());
    }
    w.bytes(&bytes);
    w.u16(u16::from(crc8(&bytes)));
    let id = &desc.identity;
    for v in [id.vendor_id, id.product_code, id.revision, id.serial_number] {
        w.u32(v);
    }
    w.zeros(2 * (word::BOOTSTRAP_MAILBOX - 0x10));
    match desc.mailbox.bootstrap {
        Some((rx, tx)) => {
            for v in [rx.start, rx.len, tx.start, tx.len] {
                w.u16(v);
            }
        }
        None => w.zeros(8),
    }
    for role in [SmRole::MailboxOut, SmRole::MailboxIn] {
        match desc.sync_manager(role) {
            Some((_, sm)) if desc.mailbox.protocols.any() => {
                w.u16(sm.start);
                w.u16(sm.len);
            }
            _ => w.zeros(4),
        }
    }
    w.u16(desc.mailbox.protocols.bits());
    w.zeros(2 * (word::SIZE - word::MAILBOX_PROTOCOLS - 1));
    w.u16(desc.eeprom.size_word());
    w.u16(desc.eeprom.version);
}

/// General category (ETG.1000.6 table 21): string indices, CoE details, flags, E-Bus current,
/// ports.
fn write_general(
    desc: &DeviceDescription,
    w: &mut Writer<'_>,
    [group, image, order, name]: [u8; 4],
) {
    let mut g = [0u8; GENERAL_LEN];
    g[0] = group;
    g[1] = image;
    g[2] = order;
    g[3] = name;
    g[5] = if desc.mailbox.protocols.coe() {
        desc.mailbox.coe.bits()
    } else {
        0
    };
    // Byte 6: FoE details (1 = supported); bytes 7..11: EoE, SoE channels, DS402
    // channels, SysmanClass, flags: none.
    g[6] = u8::from(desc.mailbox.protocols.foe());
    g[12..14].copy_from_slice(&desc.ebus_current_ma.to_le_bytes());
    let p = desc.ports;
    g[16] = p[0].code() | p[1].code() << 4;
    g[17] = p[2].code() | p[3].code() << 4;
    w.bytes(&g);
}

fn write_pdo(
    desc: &DeviceDescription,
    w: &mut Writer<'_>,
    strings: &mut StringTable,
    object: &'static ObjectDesc,
) -> Result<(), SiiError> {
    let count = desc.pdo_entries(object.index).count();
    let count = u8::try_from(count).map_err(|_| SiiError::TooManyPdoEntries {
        index: object.index,
    })?;
    let sm = if desc.pdo_is_assigned(object.index) {
        desc.sm_of_pdo(object.index).unwrap_or(PDO_NOT_ASSIGNED)
    } else {
        PDO_NOT_ASSIGNED
    };
    w.u16(object.index);
    w.u8(count);
    w.u8(sm);
    w.u8(0); // DC sync: none
    w.u8(strings.index(object.name)?);
    w.u16(0); // flags
    for entry in desc.pdo_entries(object.index) {
        let (name, data_type) = entry_name_and_type(desc, strings, entry)?;
        w.u16(entry.index);
        w.u8(entry.subindex);
        w.u8(name);
        w.u8(data_type);
        w.u8(entry.bit_len);
        w.u16(0); // flags
    }
    Ok(())
}

/// Name index and data type of a mapped entry; a gap has no name and its basic type (or 0).
fn entry_name_and_type(
    desc: &DeviceDescription,
    strings: &mut StringTable,
    entry: PdoEntry,
) -> Result<(u8, u8), SiiError> {
    match desc.mapped_entry(entry) {
        Some(e) => Ok((strings.index(e.name)?, e.data_type().code() as u8)),
        None => Ok((0, entry.index as u8)),
    }
}

#[cfg(test)]
mod tests;
