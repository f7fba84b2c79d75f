//! Reading an SII EEPROM image (ETG.1000.6 5.4, ETG.2010): zero-copy views over the bytes,
//! in the style of the [`wire`](crate::wire) layer.
//!
//! [`Sii`] gives the fixed area (words 0x00..0x3F: configuration words, checksum, identity,
//! mailbox layouts, protocols) and walks the categories from word 0x40 ([`Sii::categories`]);
//! each category body has a view ([`Strings`], [`General`], [`SyncManagers`], [`Pdos`],
//! [`DcOpModes`]). Nothing here can panic: a category that runs past the image or a list
//! whose last element is cut short is an error, not a short read, and fixed-length fields
//! outside a shorter-than-standard body read as zero.
//!
//! Dumps of real devices (the EEPROM read back with a master's tool) and the images
//! [`generate`](super::generate) writes are read the same way; the generator's tests use a
//! reader of their own, written independently from the layout tables.

use super::{category, crc8, word};
use crate::device::SmRole;
use core::fmt;

/// Why an image cannot be read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ReadError {
    /// The image is shorter than the fixed area (64 words).
    NoFixedArea {
        /// Length of the image in bytes.
        len: usize,
    },
    /// A category header starts too close to the end of the image.
    TruncatedHeader {
        /// Byte offset of the header.
        at: usize,
    },
    /// A category's length runs past the end of the image.
    CategoryOverrun {
        /// Category type.
        kind: u16,
        /// Byte offset of its header.
        at: usize,
    },
    /// A PDO's entries run past the end of its category.
    PdoOverrun {
        /// PDO index.
        index: u16,
    },
}

impl fmt::Display for ReadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NoFixedArea { len } => {
                write!(f, "{len} bytes: shorter than the 128-byte fixed area")
            }
            Self::TruncatedHeader { at } => {
                write!(
                    f,
                    "category header at byte {at:#x} cut off by the end of the image"
                )
            }
            Self::CategoryOverrun { kind, at } => write!(
                f,
                "category {kind} at byte {at:#x} runs past the end of the image"
            ),
            Self::PdoOverrun { index } => {
                write!(
                    f,
                    "PDO {index:#06x}: entries run past the end of its category"
                )
            }
        }
    }
}

/// Byte length of the fixed area.
pub const FIXED_AREA_LEN: usize = 2 * word::FIRST_CATEGORY;

fn le16(b: &[u8], at: usize) -> u16 {
    match b.get(at..at + 2) {
        Some(&[lo, hi]) => u16::from_le_bytes([lo, hi]),
        _ => 0,
    }
}

fn le32(b: &[u8], at: usize) -> u32 {
    u32::from(le16(b, at)) | u32::from(le16(b, at + 2)) << 16
}

fn byte(b: &[u8], at: usize) -> u8 {
    b.get(at).copied().unwrap_or(0)
}

/// Vendor ID, product code, revision and serial number (words 0x08..0x0F; object 0x1018).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Identity {
    /// Vendor ID.
    pub vendor_id: u32,
    /// Product code.
    pub product_code: u32,
    /// Revision number.
    pub revision: u32,
    /// Serial number.
    pub serial_number: u32,
}

/// Offsets and sizes of a mailbox pair (words 0x14..0x17 bootstrap, 0x18..0x1B standard).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MailboxLayout {
    /// Receive mailbox (master -> slave, SM0) start.
    pub receive_offset: u16,
    /// Receive mailbox size.
    pub receive_size: u16,
    /// Send mailbox (slave -> master, SM1) start.
    pub send_offset: u16,
    /// Send mailbox size.
    pub send_size: u16,
}

/// A view of a whole SII image.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Sii<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> Sii<T> {
    /// Wraps an image without checking it (fixed-area fields outside it read as zero).
    pub const fn new_unchecked(buffer: T) -> Self {
        Self { buffer }
    }

    /// Wraps an image that holds at least the fixed area.
    pub fn new_checked(buffer: T) -> Result<Self, ReadError> {
        let len = buffer.as_ref().len();
        if len < FIXED_AREA_LEN {
            return Err(ReadError::NoFixedArea { len });
        }
        Ok(Self { buffer })
    }

    /// Gives the buffer back.
    pub fn into_inner(self) -> T {
        self.buffer
    }

    /// Word `n` of the image (0 outside it).
    pub fn word(&self, n: usize) -> u16 {
        le16(self.buffer.as_ref(), 2 * n)
    }

    fn dword(&self, n: usize) -> u32 {
        le32(self.buffer.as_ref(), 2 * n)
    }

    /// The stored checksum (low byte of word 7).
    pub fn checksum(&self) -> u8 {
        self.word(word::CHECKSUM).to_le_bytes()[0]
    }

    /// Whether the checksum matches the CRC-8 of words 0..6; the ESC refuses to load its
    /// configuration (0x0502 b11) from an image where it does not.
    pub fn checksum_valid(&self) -> bool {
        match self.buffer.as_ref().get(..2 * word::CHECKSUM) {
            Some(words) => crc8(words) == self.checksum(),
            None => false,
        }
    }

    /// Identity (words 0x08..0x0F).
    pub fn identity(&self) -> Identity {
        Identity {
            vendor_id: self.dword(word::VENDOR_ID),
            product_code: self.dword(word::PRODUCT_CODE),
            revision: self.dword(word::REVISION),
            serial_number: self.dword(word::SERIAL_NUMBER),
        }
    }

    fn mailbox(&self, first: usize) -> MailboxLayout {
        MailboxLayout {
            receive_offset: self.word(first),
            receive_size: self.word(first + 1),
            send_offset: self.word(first + 2),
            send_size: self.word(first + 3),
        }
    }

    /// The bootstrap mailbox (words 0x14..0x17; all zero without BOOT support).
    pub fn bootstrap_mailbox(&self) -> MailboxLayout {
        self.mailbox(word::BOOTSTRAP_MAILBOX)
    }

    /// The standard mailbox (words 0x18..0x1B).
    pub fn standard_mailbox(&self) -> MailboxLayout {
        self.mailbox(word::STANDARD_MAILBOX)
    }

    /// Supported mailbox protocols (word 0x1C: b0 AoE, b1 EoE, b2 CoE, b3 FoE, b4 SoE, b5 VoE).
    pub fn mailbox_protocols(&self) -> u16 {
        self.word(word::MAILBOX_PROTOCOLS)
    }

    /// EEPROM size in Kbit (word 0x3E holds the size minus one).
    pub fn eeprom_kbit(&self) -> u32 {
        u32::from(self.word(word::SIZE)) + 1
    }

    /// SII version (word 0x3F).
    pub fn version(&self) -> u16 {
        self.word(word::VERSION)
    }

    /// The categories in image order, up to the end marker (0xFFFF) or the end of the image.
    pub fn categories(&self) -> Categories<'_> {
        Categories {
            image: self.buffer.as_ref(),
            at: FIXED_AREA_LEN,
            done: false,
        }
    }

    /// The body of the first category of type `kind`: `None` when the list ends without
    /// one, an error when the list is broken before it.
    pub fn category(&self, kind: u16) -> Option<Result<&[u8], ReadError>> {
        for c in self.categories() {
            match c {
                Ok(c) if c.kind == kind => return Some(Ok(c.data)),
                Ok(_) => {}
                Err(e) => return Some(Err(e)),
            }
        }
        None
    }

    /// The Strings category (empty when there is none or the list is broken).
    pub fn strings(&self) -> Strings<'_> {
        let data = match self.category(category::STRINGS) {
            Some(Ok(data)) => data,
            _ => &[],
        };
        Strings::new(data)
    }
}

/// One category: its type and its body.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Category<'a> {
    /// Category type (bit 15: vendor specific).
    pub kind: u16,
    /// Byte offset of its header in the image.
    pub at: usize,
    /// The body (length = the header's word count x 2).
    pub data: &'a [u8],
}

/// Iterator over the categories of an image; stops after the end marker, the end of the
/// image or the first error.
#[derive(Debug, Clone)]
pub struct Categories<'a> {
    image: &'a [u8],
    at: usize,
    done: bool,
}

impl<'a> Iterator for Categories<'a> {
    type Item = Result<Category<'a>, ReadError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let at = self.at;
        let rest = self.image.get(at..).unwrap_or(&[]);
        // An image may end right after its last category (the EEPROM's erased rest cut
        // off) or with a lone end marker word.
        if rest.is_empty() || le16(rest, 0) == category::END && rest.len() >= 2 {
            self.done = true;
            return None;
        }
        let Some(header) = rest.get(..4) else {
            self.done = true;
            return Some(Err(ReadError::TruncatedHeader { at }));
        };
        let kind = le16(header, 0);
        let len = 2 * usize::from(le16(header, 2));
        let Some(data) = rest.get(4..4 + len) else {
            self.done = true;
            return Some(Err(ReadError::CategoryOverrun { kind, at }));
        };
        self.at = at + 4 + len;
        Some(Ok(Category { kind, at, data }))
    }
}

/// The Strings category (10): a count, then length-prefixed strings; index 1 is the first.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Strings<'a> {
    data: &'a [u8],
}

impl<'a> Strings<'a> {
    /// A view of a Strings category body.
    pub const fn new(data: &'a [u8]) -> Self {
        Self { data }
    }

    /// The count the category declares.
    pub fn declared_count(&self) -> u8 {
        byte(self.data, 0)
    }

    /// String `index` (1-based; 0 means "no string" and gives `None`, as does an index past
    /// the end or a string cut off by the end of the category).
    pub fn get(&self, index: u8) -> Option<&'a [u8]> {
        self.iter().nth(usize::from(index).checked_sub(1)?)
    }

    /// The strings in order, as many as the category holds whole (at most the declared count).
    pub fn iter(&self) -> StringIter<'a> {
        StringIter {
            rest: self.data.get(1..).unwrap_or(&[]),
            left: self.declared_count(),
        }
    }
}

/// Iterator of [`Strings::iter`].
#[derive(Debug, Clone)]
pub struct StringIter<'a> {
    rest: &'a [u8],
    left: u8,
}

impl<'a> Iterator for StringIter<'a> {
    type Item = &'a [u8];

    fn next(&mut self) -> Option<&'a [u8]> {
        let (&len, tail) = self.rest.split_first()?;
        if self.left == 0 {
            return None;
        }
        let s = tail.get(..usize::from(len))?;
        self.rest = &tail[s.len()..];
        self.left -= 1;
        Some(s)
    }
}

/// The General category (30): indices into Strings, CoE/FoE/EoE details, flags, ports.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct General<'a> {
    data: &'a [u8],
}

impl<'a> General<'a> {
    /// A view of a General category body (fields past a short body read as zero).
    pub const fn new(data: &'a [u8]) -> Self {
        Self { data }
    }

    /// Group type string index.
    pub fn group_index(&self) -> u8 {
        byte(self.data, 0)
    }

    /// Image name string index.
    pub fn image_index(&self) -> u8 {
        byte(self.data, 1)
    }

    /// Order code string index.
    pub fn order_index(&self) -> u8 {
        byte(self.data, 2)
    }

    /// Device name string index.
    pub fn name_index(&self) -> u8 {
        byte(self.data, 3)
    }

    /// CoE details: b0 SDO, b1 SDO Information, b2 PDO assign, b3 PDO configuration,
    /// b4 upload at startup, b5 SDO complete access.
    pub fn coe_details(&self) -> u8 {
        byte(self.data, 5)
    }

    /// FoE details (b0 supported).
    pub fn foe_details(&self) -> u8 {
        byte(self.data, 6)
    }

    /// EoE details (b0 supported).
    pub fn eoe_details(&self) -> u8 {
        byte(self.data, 7)
    }

    /// Flags: b0 SAFEOP enable, b1 not LRW, b2 mailbox data link layer, b3 ID in AL status,
    /// b4 ID in physical memory.
    pub fn flags(&self) -> u8 {
        byte(self.data, 11)
    }

    /// Current consumption from the E-bus (mA; negative: the device feeds it).
    pub fn ebus_current_ma(&self) -> i16 {
        le16(self.data, 12) as i16
    }

    /// Physical ports, a nibble each (0 none, 1 MII, 2 reserved, 3 E-bus).
    pub fn physical_ports(&self) -> u16 {
        le16(self.data, 16)
    }

    /// Physical memory address of the explicit device ID.
    pub fn id_address(&self) -> u16 {
        le16(self.data, 18)
    }
}

/// One entry of the SyncM category (41).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SyncManagerEntry {
    /// Physical start address.
    pub start: u16,
    /// Default length.
    pub len: u16,
    /// Control register value.
    pub control: u8,
    /// Status register value (not used by masters).
    pub status: u8,
    /// Enable byte: b0 enable, b1 fixed content, b2 virtual, b3 OP only.
    pub enable: u8,
    /// Type byte (ETG.2010 table 9; [`SmRole::from_sii_type`]).
    pub sm_type: u8,
}

impl SyncManagerEntry {
    /// What the SyncManager is for (`None`: unused or an unknown type).
    pub const fn role(&self) -> Option<SmRole> {
        SmRole::from_sii_type(self.sm_type)
    }
}

/// The SyncM category (41): 8 bytes per SyncManager; a short tail is ignored.
#[derive(Debug, Clone)]
pub struct SyncManagers<'a> {
    chunks: core::slice::ChunksExact<'a, u8>,
}

impl<'a> SyncManagers<'a> {
    /// A view of a SyncM category body.
    pub fn new(data: &'a [u8]) -> Self {
        Self {
            chunks: data.chunks_exact(8),
        }
    }
}

impl Iterator for SyncManagers<'_> {
    type Item = SyncManagerEntry;

    fn next(&mut self) -> Option<SyncManagerEntry> {
        let c = self.chunks.next()?;
        Some(SyncManagerEntry {
            start: le16(c, 0),
            len: le16(c, 2),
            control: byte(c, 4),
            status: byte(c, 5),
            enable: byte(c, 6),
            sm_type: byte(c, 7),
        })
    }
}

/// Length of a PDO header and of a PDO entry in the TxPDO/RxPDO categories.
const PDO_HEADER_LEN: usize = 8;
const PDO_ENTRY_LEN: usize = 8;

/// One PDO of a TxPDO (50) or RxPDO (51) category.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Pdo<'a> {
    /// PDO index (0x1600.., 0x1A00..).
    pub index: u16,
    /// SyncManager it is assigned to by default (0xFF: none).
    pub sync_manager: u8,
    /// DC sync unit.
    pub dc_sync: u8,
    /// Name string index.
    pub name_index: u8,
    /// Flags (b0 mandatory, b1 default, b4 fixed content, ...).
    pub flags: u16,
    entries: &'a [u8],
}

impl<'a> Pdo<'a> {
    /// Its mapped entries.
    pub fn entries(&self) -> PdoEntries<'a> {
        PdoEntries {
            chunks: self.entries.chunks_exact(PDO_ENTRY_LEN),
        }
    }

    /// Number of entries.
    pub fn entry_count(&self) -> usize {
        self.entries.len() / PDO_ENTRY_LEN
    }
}

/// One mapped entry of a [`Pdo`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PdoEntry {
    /// Object index (0 with sub-index 0: a gap).
    pub index: u16,
    /// Sub-index.
    pub sub_index: u8,
    /// Name string index.
    pub name_index: u8,
    /// Data type (CoE code).
    pub data_type: u8,
    /// Bit length.
    pub bit_len: u8,
    /// Flags.
    pub flags: u16,
}

/// Iterator of [`Pdo::entries`].
#[derive(Debug, Clone)]
pub struct PdoEntries<'a> {
    chunks: core::slice::ChunksExact<'a, u8>,
}

impl Iterator for PdoEntries<'_> {
    type Item = PdoEntry;

    fn next(&mut self) -> Option<PdoEntry> {
        let c = self.chunks.next()?;
        Some(PdoEntry {
            index: le16(c, 0),
            sub_index: byte(c, 2),
            name_index: byte(c, 3),
            data_type: byte(c, 4),
            bit_len: byte(c, 5),
            flags: le16(c, 6),
        })
    }
}

/// The PDOs of a TxPDO or RxPDO category; stops after the first error. The generator pads
/// the category to whole words, so fewer than 8 bytes left end the list.
#[derive(Debug, Clone)]
pub struct Pdos<'a> {
    rest: &'a [u8],
}

impl<'a> Pdos<'a> {
    /// A view of a TxPDO or RxPDO category body.
    pub const fn new(data: &'a [u8]) -> Self {
        Self { rest: data }
    }
}

impl<'a> Iterator for Pdos<'a> {
    type Item = Result<Pdo<'a>, ReadError>;

    fn next(&mut self) -> Option<Self::Item> {
        let header = self.rest.get(..PDO_HEADER_LEN)?;
        let index = le16(header, 0);
        let len = usize::from(byte(header, 2)) * PDO_ENTRY_LEN;
        let Some(entries) = self.rest.get(PDO_HEADER_LEN..PDO_HEADER_LEN + len) else {
            self.rest = &[];
            return Some(Err(ReadError::PdoOverrun { index }));
        };
        self.rest = &self.rest[PDO_HEADER_LEN + len..];
        Some(Ok(Pdo {
            index,
            sync_manager: byte(header, 3),
            dc_sync: byte(header, 4),
            name_index: byte(header, 5),
            flags: le16(header, 6),
            entries,
        }))
    }
}

/// One operation mode of the DC category (60).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DcOpMode {
    /// SYNC0 cycle time (ns; 0: the master's cycle).
    pub cycle_time_sync0: u32,
    /// SYNC0 shift (ns).
    pub shift_time_sync0: u32,
    /// SYNC1 shift (ns).
    pub shift_time_sync1: u32,
    /// SYNC1 cycle factor.
    pub sync1_factor: i16,
    /// AssignActivate (0x0980/0x0981; 0x0300 = SYNC0).
    pub assign_activate: u16,
    /// SYNC0 cycle factor.
    pub sync0_factor: i16,
    /// Name string index.
    pub name_index: u8,
    /// Description string index.
    pub description_index: u8,
}

/// Length of one DC operation mode.
const DC_OP_MODE_LEN: usize = 24;

/// The DC category (60): 24 bytes per operation mode; a short tail is ignored.
#[derive(Debug, Clone)]
pub struct DcOpModes<'a> {
    chunks: core::slice::ChunksExact<'a, u8>,
}

impl<'a> DcOpModes<'a> {
    /// A view of a DC category body.
    pub fn new(data: &'a [u8]) -> Self {
        Self {
            chunks: data.chunks_exact(DC_OP_MODE_LEN),
        }
    }
}

impl Iterator for DcOpModes<'_> {
    type Item = DcOpMode;

    fn next(&mut self) -> Option<DcOpMode> {
        let c = self.chunks.next()?;
        Some(DcOpMode {
            cycle_time_sync0: le32(c, 0),
            shift_time_sync0: le32(c, 4),
            shift_time_sync1: le32(c, 8),
            sync1_factor: le16(c, 12) as i16,
            assign_activate: le16(c, 14),
            sync0_factor: le16(c, 16) as i16,
            name_index: byte(c, 18),
            description_index: byte(c, 19),
        })
    }
}

#[cfg(test)]
mod tests;
