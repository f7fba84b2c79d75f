//! The header of an update file (`.efw`), in the first 256 bytes of the file and of the
//! application slot ([`crate::platform::boot::layout::HEADER_BLOCK`]). Little-endian:
//!
//! ```text
//!  byte 0..4      magic "AEFW"
//!  byte 4..6      format version u16 (1)
//!  byte 6..8      header length u16 (256)
//!  byte 8..12     image length u32: the bytes after the header block
//!  byte 12..16    image CRC-32 (crate::platform::boot::crc32) of those bytes
//!  byte 16..20    vendor ID the image is built for (0x1018:01)
//!  byte 20..24    product code (0x1018:02)
//!  byte 24..28    hardware revision of the board
//!  byte 28..32    load address: where the image's first byte (its vector table) goes
//!  byte 32..64    firmware version, ASCII, NUL-padded (the image's 0x100A)
//!  byte 64..68    board design the image runs on (crate::platform::board)
//!  byte 68..72    board options the image needs (crate::platform::board::Options)
//!                 (both reserved, 0xFF, before there were products)
//!  byte 72..252   reserved, 0xFF
//!  byte 252..256  header CRC-32 of bytes 0..252
//! ```
//!
//! # Which files a bootloader accepts ([`HeaderRepr::check`])
//!
//! The bootloader belongs to the board, not to a product: it takes the file of any product
//! built for its board, so one product can be updated into another on the same board. A
//! file is accepted when its vendor ID, board design and hardware revision are the
//! board's, the board has every option the file needs (a product with CANopen needs the
//! CAN transceiver), and it is linked for the application slot and fits it. The product
//! code is not compared: it says which product the file holds.
//!
//! The board and its options took reserved bytes, so the format stays 1: a bootloader from
//! before products (it compares the product code and reads no reserved byte; the header
//! CRC covers them all) takes `analog-io`'s files, whose product code is the one it knows,
//! and refuses the others, so a board in the field is updated over FoE without a probe. A
//! file from before products has 0xFF where the board is and is refused here as for
//! another board.
//!
//! A view [`Header`] over the bytes and a [`HeaderRepr`] with `parse`/`emit`, as the `wire`
//! layer of coe-core does it.

use super::crc32::crc32;
use super::layout::{APP_VECTORS, HEADER_BLOCK, MAX_IMAGE};
use crate::platform::board::{Board, Options};
use core::fmt;

mod field {
    use core::ops::Range;

    pub const MAGIC: Range<usize> = 0..4;
    pub const FORMAT: Range<usize> = 4..6;
    pub const HEADER_LEN: Range<usize> = 6..8;
    pub const IMAGE_LEN: Range<usize> = 8..12;
    pub const IMAGE_CRC: Range<usize> = 12..16;
    pub const VENDOR_ID: Range<usize> = 16..20;
    pub const PRODUCT_CODE: Range<usize> = 20..24;
    pub const HARDWARE_REVISION: Range<usize> = 24..28;
    pub const LOAD_ADDRESS: Range<usize> = 28..32;
    pub const VERSION: Range<usize> = 32..64;
    pub const BOARD: Range<usize> = 64..68;
    pub const NEEDS: Range<usize> = 68..72;
    pub const RESERVED: Range<usize> = 72..252;
    pub const HEADER_CRC: Range<usize> = 252..256;
}

/// The header block's length.
pub const LEN: usize = HEADER_BLOCK as usize;
/// The magic, bytes "AEFW".
pub const MAGIC: [u8; 4] = *b"AEFW";
/// The format this code reads and writes.
pub const FORMAT_VERSION: u16 = 1;
/// Bytes of the version text.
pub const VERSION_LEN: usize = 32;

/// Why bytes are not a header.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum HeaderError {
    /// Fewer than 256 bytes.
    Truncated,
    /// Not "AEFW": not an update file (or an erased or partly written block).
    BadMagic,
    /// A format version this code does not know.
    UnknownFormat(u16),
    /// The header length field is not 256.
    BadHeaderLength(u16),
    /// The header's own CRC is wrong: a damaged or partly written header.
    BadHeaderCrc,
}

impl HeaderError {
    /// For a person.
    pub const fn message(&self) -> &'static str {
        match self {
            Self::Truncated => "shorter than the header",
            Self::BadMagic => "not an .efw file",
            Self::UnknownFormat(_) => "unknown .efw format",
            Self::BadHeaderLength(_) => "bad header length",
            Self::BadHeaderCrc => "header CRC wrong",
        }
    }
}

impl fmt::Display for HeaderError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.message())
    }
}

/// Why a valid header does not fit this module.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Mismatch {
    /// Built for another vendor.
    Vendor,
    /// Built for another board design.
    Board,
    /// Built for another hardware revision.
    HardwareRevision,
    /// Needs a part the board does not have (e.g. the CAN transceiver).
    Options,
    /// Linked for another address.
    LoadAddress,
    /// Longer than the application slot.
    TooLarge,
}

impl Mismatch {
    /// For a person (and the FoE error text).
    pub const fn message(&self) -> &'static str {
        match self {
            Self::Vendor => "other vendor ID",
            Self::Board => "other board",
            Self::HardwareRevision => "other hardware revision",
            Self::Options => "board lacks a part",
            Self::LoadAddress => "other load address",
            Self::TooLarge => "image too large",
        }
    }
}

/// What an image is built for: the product, the board and what it needs of the board.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Target {
    /// Vendor ID (0x1018:01).
    pub vendor_id: u32,
    /// Product code (0x1018:02).
    pub product_code: u32,
    /// Hardware revision of the board.
    pub hardware_revision: u32,
    /// The board design.
    pub board: u32,
    /// The board options the image needs.
    pub needs: Options,
}

impl Target {
    /// A product's target: its identity on `board`, needing `needs` of it.
    pub const fn new(vendor_id: u32, product_code: u32, board: &Board, needs: Options) -> Self {
        Self {
            vendor_id,
            product_code,
            hardware_revision: board.revision,
            board: board.design,
            needs,
        }
    }
}

/// A read/write view of a header block.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Header<T: AsRef<[u8]>> {
    buffer: T,
}

fn u16_at(b: &[u8], r: core::ops::Range<usize>) -> u16 {
    b.get(r)
        .and_then(|s| <[u8; 2]>::try_from(s).ok())
        .map_or(0, u16::from_le_bytes)
}

fn u32_at(b: &[u8], r: core::ops::Range<usize>) -> u32 {
    b.get(r)
        .and_then(|s| <[u8; 4]>::try_from(s).ok())
        .map_or(0, u32::from_le_bytes)
}

fn put(b: &mut [u8], r: core::ops::Range<usize>, value: &[u8]) {
    if let Some(dst) = b.get_mut(r) {
        for (d, s) in dst.iter_mut().zip(value) {
            *d = *s;
        }
    }
}

impl<T: AsRef<[u8]>> Header<T> {
    /// Wraps a buffer without checking it (for emitting).
    pub const fn new_unchecked(buffer: T) -> Self {
        Self { buffer }
    }

    /// Wraps a buffer of at least 256 bytes.
    pub fn new_checked(buffer: T) -> Result<Self, HeaderError> {
        if buffer.as_ref().len() < LEN {
            return Err(HeaderError::Truncated);
        }
        Ok(Self { buffer })
    }

    /// The magic bytes.
    pub fn magic(&self) -> [u8; 4] {
        u32_at(self.buffer.as_ref(), field::MAGIC).to_le_bytes()
    }

    /// Format version.
    pub fn format_version(&self) -> u16 {
        u16_at(self.buffer.as_ref(), field::FORMAT)
    }

    /// Header length field.
    pub fn header_len(&self) -> u16 {
        u16_at(self.buffer.as_ref(), field::HEADER_LEN)
    }

    /// Image length.
    pub fn image_len(&self) -> u32 {
        u32_at(self.buffer.as_ref(), field::IMAGE_LEN)
    }

    /// Image CRC-32.
    pub fn image_crc(&self) -> u32 {
        u32_at(self.buffer.as_ref(), field::IMAGE_CRC)
    }

    /// Vendor ID.
    pub fn vendor_id(&self) -> u32 {
        u32_at(self.buffer.as_ref(), field::VENDOR_ID)
    }

    /// Product code.
    pub fn product_code(&self) -> u32 {
        u32_at(self.buffer.as_ref(), field::PRODUCT_CODE)
    }

    /// Hardware revision.
    pub fn hardware_revision(&self) -> u32 {
        u32_at(self.buffer.as_ref(), field::HARDWARE_REVISION)
    }

    /// Load address.
    pub fn load_address(&self) -> u32 {
        u32_at(self.buffer.as_ref(), field::LOAD_ADDRESS)
    }

    /// Board design.
    pub fn board(&self) -> u32 {
        u32_at(self.buffer.as_ref(), field::BOARD)
    }

    /// Board options needed.
    pub fn needs(&self) -> u32 {
        u32_at(self.buffer.as_ref(), field::NEEDS)
    }

    /// The version field (NUL-padded).
    pub fn version(&self) -> [u8; VERSION_LEN] {
        let mut v = [0u8; VERSION_LEN];
        if let Some(src) = self.buffer.as_ref().get(field::VERSION) {
            v.copy_from_slice(src);
        }
        v
    }

    /// The header CRC field.
    pub fn header_crc(&self) -> u32 {
        u32_at(self.buffer.as_ref(), field::HEADER_CRC)
    }

    /// The CRC of bytes 0..252 (what the header CRC field must hold).
    pub fn computed_header_crc(&self) -> u32 {
        self.buffer
            .as_ref()
            .get(..field::HEADER_CRC.start)
            .map_or(0, crc32)
    }
}

impl<T: AsRef<[u8]> + AsMut<[u8]>> Header<T> {
    fn set(&mut self, r: core::ops::Range<usize>, value: &[u8]) {
        put(self.buffer.as_mut(), r, value)
    }
}

/// A header as values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct HeaderRepr {
    /// Bytes after the header block.
    pub image_len: u32,
    /// CRC-32 of those bytes.
    pub image_crc: u32,
    /// Vendor ID built for.
    pub vendor_id: u32,
    /// Product code built for.
    pub product_code: u32,
    /// Hardware revision built for.
    pub hardware_revision: u32,
    /// Address of the image's first byte.
    pub load_address: u32,
    /// Firmware version text, NUL-padded.
    pub version: [u8; VERSION_LEN],
    /// Board design built for.
    pub board: u32,
    /// Board options the image needs.
    pub needs: Options,
}

impl HeaderRepr {
    /// The version as text: up to the first NUL; `None` if that is not UTF-8.
    pub fn version_str(&self) -> Option<&str> {
        let end = self
            .version
            .iter()
            .position(|b| *b == 0)
            .unwrap_or(VERSION_LEN);
        core::str::from_utf8(self.version.get(..end)?).ok()
    }

    /// The version field for `text` (cut to 32 bytes, NUL-padded).
    pub fn version_field(text: &str) -> [u8; VERSION_LEN] {
        let mut v = [0u8; VERSION_LEN];
        for (d, s) in v.iter_mut().zip(text.as_bytes()) {
            *d = *s;
        }
        v
    }

    /// Parses and checks a header block: magic, format, length, header CRC.
    pub fn parse<T: AsRef<[u8]>>(h: &Header<T>) -> Result<Self, HeaderError> {
        if h.buffer.as_ref().len() < LEN {
            return Err(HeaderError::Truncated);
        }
        if h.magic() != MAGIC {
            return Err(HeaderError::BadMagic);
        }
        if h.format_version() != FORMAT_VERSION {
            return Err(HeaderError::UnknownFormat(h.format_version()));
        }
        if h.header_len() != HEADER_BLOCK as u16 {
            return Err(HeaderError::BadHeaderLength(h.header_len()));
        }
        if h.header_crc() != h.computed_header_crc() {
            return Err(HeaderError::BadHeaderCrc);
        }
        Ok(Self {
            image_len: h.image_len(),
            image_crc: h.image_crc(),
            vendor_id: h.vendor_id(),
            product_code: h.product_code(),
            hardware_revision: h.hardware_revision(),
            load_address: h.load_address(),
            version: h.version(),
            board: h.board(),
            needs: Options(h.needs()),
        })
    }

    /// Writes the whole block (reserved bytes 0xFF, header CRC last); `Err(Truncated)` for a
    /// buffer below 256 bytes.
    pub fn emit<T: AsRef<[u8]> + AsMut<[u8]>>(&self, h: &mut Header<T>) -> Result<(), HeaderError> {
        if h.buffer.as_ref().len() < LEN {
            return Err(HeaderError::Truncated);
        }
        h.set(field::MAGIC, &MAGIC);
        h.set(field::FORMAT, &FORMAT_VERSION.to_le_bytes());
        h.set(field::HEADER_LEN, &(HEADER_BLOCK as u16).to_le_bytes());
        h.set(field::IMAGE_LEN, &self.image_len.to_le_bytes());
        h.set(field::IMAGE_CRC, &self.image_crc.to_le_bytes());
        h.set(field::VENDOR_ID, &self.vendor_id.to_le_bytes());
        h.set(field::PRODUCT_CODE, &self.product_code.to_le_bytes());
        h.set(
            field::HARDWARE_REVISION,
            &self.hardware_revision.to_le_bytes(),
        );
        h.set(field::LOAD_ADDRESS, &self.load_address.to_le_bytes());
        h.set(field::VERSION, &self.version);
        h.set(field::BOARD, &self.board.to_le_bytes());
        h.set(field::NEEDS, &self.needs.0.to_le_bytes());
        h.set(field::RESERVED, &[0xFF; 252 - 72]);
        let crc = h.computed_header_crc();
        h.set(field::HEADER_CRC, &crc.to_le_bytes());
        Ok(())
    }

    /// Whether the image runs on `board` (the rule in the module's documentation): vendor,
    /// board design and revision, the options it needs, load address and length; any
    /// product.
    pub fn check(&self, board: &Board) -> Result<(), Mismatch> {
        if self.vendor_id != board.vendor_id {
            return Err(Mismatch::Vendor);
        }
        if self.board != board.design {
            return Err(Mismatch::Board);
        }
        if self.hardware_revision != board.revision {
            return Err(Mismatch::HardwareRevision);
        }
        if !board.options.covers(self.needs) {
            return Err(Mismatch::Options);
        }
        if self.load_address != APP_VECTORS {
            return Err(Mismatch::LoadAddress);
        }
        if self.image_len > MAX_IMAGE {
            return Err(Mismatch::TooLarge);
        }
        Ok(())
    }

    /// The header of `image` built for `target` with `version`.
    pub fn for_image(image: &[u8], target: &Target, version: &str) -> Self {
        Self {
            image_len: u32::try_from(image.len()).unwrap_or(u32::MAX),
            image_crc: crc32(image),
            vendor_id: target.vendor_id,
            product_code: target.product_code,
            hardware_revision: target.hardware_revision,
            load_address: APP_VECTORS,
            version: Self::version_field(version),
            board: target.board,
            needs: target.needs,
        }
    }

    /// The header block's bytes.
    pub fn to_bytes(&self) -> [u8; LEN] {
        let mut block = [0u8; LEN];
        // A 256-byte buffer always takes the header.
        let _ = self.emit(&mut Header::new_unchecked(&mut block[..]));
        block
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const BOARD: Board = Board {
        name: "test board",
        vendor_id: 0,
        design: 0x1754,
        revision: 1,
        options: Options::NONE,
    };
    const TARGET: Target = Target::new(0, 0x1754, &BOARD, Options::NONE);

    /// The first 72 bytes of the header of a 0x1234-byte image with CRC 0xA1B2C3D4, vendor 0,
    /// product 0x1754, hardware revision 1, version "0.1.0", board 0x1754 needing option 1;
    /// the rest 0xFF and the CRC.
    const GOLDEN_HEAD: [u8; 72] = [
        b'A', b'E', b'F', b'W', 0x01, 0x00, 0x00, 0x01, // magic, format 1, length 256
        0x34, 0x12, 0x00, 0x00, 0xD4, 0xC3, 0xB2, 0xA1, // image length, CRC
        0x00, 0x00, 0x00, 0x00, 0x54, 0x17, 0x00, 0x00, // vendor, product
        0x01, 0x00, 0x00, 0x00, 0x00, 0x31, 0x00, 0x00, // hardware revision, load address
        b'0', b'.', b'1', b'.', b'0', 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, // version
        0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0x54, 0x17, 0x00, 0x00, 0x01, 0x00, 0x00,
        0x00, // board, needs
    ];

    fn repr() -> HeaderRepr {
        HeaderRepr {
            image_len: 0x1234,
            image_crc: 0xA1B2_C3D4,
            vendor_id: 0,
            product_code: 0x1754,
            hardware_revision: 1,
            load_address: 0x3100,
            version: HeaderRepr::version_field("0.1.0"),
            board: 0x1754,
            needs: Options::CAN_TRANSCEIVER,
        }
    }

    fn golden() -> [u8; LEN] {
        let mut b = [0xFFu8; LEN];
        b[..72].copy_from_slice(&GOLDEN_HEAD);
        let crc = crc32(&b[..252]);
        b[252..].copy_from_slice(&crc.to_le_bytes());
        b
    }

    #[test]
    fn deconstruct() {
        let g = golden();
        let h = Header::new_checked(&g[..]).unwrap();
        assert_eq!(h.magic(), *b"AEFW");
        assert_eq!(h.format_version(), 1);
        assert_eq!(h.header_len(), 256);
        assert_eq!(h.image_len(), 0x1234);
        assert_eq!(h.image_crc(), 0xA1B2_C3D4);
        assert_eq!(h.product_code(), 0x1754);
        assert_eq!(h.hardware_revision(), 1);
        assert_eq!(h.load_address(), 0x3100);
        assert_eq!(h.board(), 0x1754);
        assert_eq!(h.needs(), 1);
        assert_eq!(h.header_crc(), h.computed_header_crc());
    }

    #[test]
    fn parse_and_emit_are_golden() {
        let g = golden();
        let parsed = HeaderRepr::parse(&Header::new_unchecked(&g[..])).unwrap();
        assert_eq!(parsed, repr());
        assert_eq!(parsed.version_str(), Some("0.1.0"));
        let mut out = [0xA5u8; LEN + 4];
        repr()
            .emit(&mut Header::new_unchecked(&mut out[..]))
            .unwrap();
        assert_eq!(out[..LEN], g);
        assert_eq!(out[LEN..], [0xA5; 4]);
        assert_eq!(repr().to_bytes(), g);
    }

    #[test]
    fn every_damage_is_found() {
        let g = golden();
        assert_eq!(
            HeaderRepr::parse(&Header::new_unchecked(&g[..255])),
            Err(HeaderError::Truncated)
        );
        assert_eq!(
            Header::new_checked(&g[..255]).unwrap_err(),
            HeaderError::Truncated
        );
        let erased = [0xFFu8; LEN];
        assert_eq!(
            HeaderRepr::parse(&Header::new_unchecked(&erased[..])),
            Err(HeaderError::BadMagic)
        );
        let mut b = g;
        b[4] = 2;
        assert_eq!(
            HeaderRepr::parse(&Header::new_unchecked(&b[..])),
            Err(HeaderError::UnknownFormat(2))
        );
        let mut b = g;
        b[7] = 2;
        assert_eq!(
            HeaderRepr::parse(&Header::new_unchecked(&b[..])),
            Err(HeaderError::BadHeaderLength(0x200))
        );
        // Any other byte changed, or the block half written (the rest erased): CRC.
        for i in [8, 13, 20, 25, 40, 66, 69, 100, 251, 252, 255] {
            let mut b = g;
            b[i] ^= 0x01;
            assert_eq!(
                HeaderRepr::parse(&Header::new_unchecked(&b[..])),
                Err(HeaderError::BadHeaderCrc),
                "byte {i}"
            );
        }
        let mut half = g;
        half[128..].fill(0xFF);
        assert_eq!(
            HeaderRepr::parse(&Header::new_unchecked(&half[..])),
            Err(HeaderError::BadHeaderCrc)
        );
    }

    /// The rule: vendor, board, revision and the options the board has; any product.
    /// A file from before products: format 1 with the board and options bytes still
    /// reserved (0xFF). It parses, and the check refuses it as for another board.
    #[test]
    fn a_file_from_before_products_is_for_another_board() {
        let mut b = golden();
        b[64..72].fill(0xFF);
        let crc = crc32(&b[..252]);
        b[252..].copy_from_slice(&crc.to_le_bytes());
        let r = HeaderRepr::parse(&Header::new_unchecked(&b[..])).unwrap();
        assert_eq!((r.board, r.needs.0), (u32::MAX, u32::MAX));
        assert_eq!(r.product_code, 0x1754);
        assert_eq!(r.check(&BOARD), Err(Mismatch::Board));
    }

    #[test]
    fn compatibility() {
        let can_board = Board {
            options: Options::CAN_TRANSCEIVER,
            ..BOARD
        };
        assert_eq!(repr().check(&can_board), Ok(()));
        assert_eq!(repr().check(&BOARD), Err(Mismatch::Options));
        let plain = HeaderRepr {
            needs: Options::NONE,
            ..repr()
        };
        assert_eq!(plain.check(&BOARD), Ok(()));
        assert_eq!(
            plain.check(&can_board),
            Ok(()),
            "a plain image on the CAN board"
        );
        let other = |f: fn(&mut HeaderRepr)| {
            let mut r = repr();
            f(&mut r);
            r.check(&can_board)
        };
        assert_eq!(
            other(|r| r.product_code = 0x1755),
            Ok(()),
            "another product"
        );
        assert_eq!(other(|r| r.vendor_id = 2), Err(Mismatch::Vendor));
        assert_eq!(other(|r| r.board = 0x1769), Err(Mismatch::Board));
        assert_eq!(
            other(|r| r.hardware_revision = 2),
            Err(Mismatch::HardwareRevision)
        );
        assert_eq!(other(|r| r.load_address = 0), Err(Mismatch::LoadAddress));
        assert_eq!(
            other(|r| r.image_len = MAX_IMAGE + 1),
            Err(Mismatch::TooLarge)
        );
        assert_eq!(other(|r| r.image_len = MAX_IMAGE), Ok(()));
    }

    #[test]
    fn for_image_and_version_text() {
        let image = [1u8, 2, 3];
        let r = HeaderRepr::for_image(&image, &TARGET, "1.2.3-rc.1");
        assert_eq!(r.image_len, 3);
        assert_eq!(r.image_crc, crc32(&image));
        assert_eq!(r.version_str(), Some("1.2.3-rc.1"));
        let long = HeaderRepr::version_field("0123456789012345678901234567890123456789");
        assert_eq!(long.len(), 32);
        assert_eq!(long[31], b'1');
        let mut bad = r;
        bad.version[0] = 0xFF;
        assert_eq!(bad.version_str(), None);
    }
}
