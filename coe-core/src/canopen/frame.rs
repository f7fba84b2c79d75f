//! The classical CAN data frame (ISO 11898-1) as the CANopen layer sees it: an 11-bit
//! identifier, the remote (RTR) bit and up to 8 data bytes. CiA 301 uses only base-format
//! (11-bit) identifiers in the predefined connection set; 29-bit identifiers are refused
//! where a COB-ID is configured ([`CobId`]).
//!
//! [`CanFrame::bits_on_wire`] gives the frame's length on the bus, stuff bits included, so
//! a bus model (or a latency budget) can turn a frame into time at a bit rate.

/// The highest 11-bit identifier.
pub const MAX_ID: u16 = 0x7FF;

/// Why a frame could not be built.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FrameError {
    /// The identifier does not fit 11 bits.
    IdTooLarge,
    /// More than 8 data bytes (or a DLC above 8).
    TooLong,
}

/// A classical CAN frame with an 11-bit identifier.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CanFrame {
    id: u16,
    rtr: bool,
    dlc: u8,
    data: [u8; 8],
}

impl CanFrame {
    /// A data frame; `Err` for an identifier above 0x7FF or more than 8 bytes.
    pub fn new(id: u16, data: &[u8]) -> Result<Self, FrameError> {
        if id > MAX_ID {
            return Err(FrameError::IdTooLarge);
        }
        let dlc = u8::try_from(data.len())
            .ok()
            .filter(|n| *n <= 8)
            .ok_or(FrameError::TooLong)?;
        let mut bytes = [0u8; 8];
        if let Some(dst) = bytes.get_mut(..data.len()) {
            dst.copy_from_slice(data);
        }
        Ok(Self {
            id,
            rtr: false,
            dlc,
            data: bytes,
        })
    }

    /// A remote frame asking for `dlc` bytes (CiA 301 node guarding uses DLC 1 or 0).
    pub fn remote(id: u16, dlc: u8) -> Result<Self, FrameError> {
        if id > MAX_ID {
            return Err(FrameError::IdTooLarge);
        }
        if dlc > 8 {
            return Err(FrameError::TooLong);
        }
        Ok(Self {
            id,
            rtr: true,
            dlc,
            data: [0; 8],
        })
    }

    /// The identifier (0..=0x7FF).
    pub const fn id(&self) -> u16 {
        self.id
    }

    /// True for a remote (RTR) frame.
    pub const fn is_remote(&self) -> bool {
        self.rtr
    }

    /// The data length code (0..=8).
    pub const fn dlc(&self) -> u8 {
        self.dlc
    }

    /// The data bytes (empty for a remote frame).
    pub fn data(&self) -> &[u8] {
        let n = if self.rtr { 0 } else { usize::from(self.dlc) };
        self.data.get(..n).unwrap_or(&[])
    }

    /// Bits of the frame on the bus from the start of frame to the end of the intermission:
    /// SOF, arbitration, control, data and CRC fields with their stuff bits (a complement
    /// after five equal bits), then the fixed-form tail (CRC delimiter, ACK slot and
    /// delimiter, 7 bits end of frame, 3 bits intermission), which is not stuffed.
    pub fn bits_on_wire(&self) -> u32 {
        // SOF (0), identifier, RTR, IDE (0), r0 (0), DLC: 19 bits; data; CRC-15.
        let mut stream = BitStream::default();
        stream.push(0, 1);
        stream.push(u32::from(self.id), 11);
        stream.push(u32::from(self.rtr), 1);
        stream.push(0, 2);
        stream.push(u32::from(self.dlc), 4);
        for byte in self.data() {
            stream.push(u32::from(*byte), 8);
        }
        let crc = stream.crc;
        stream.push(u32::from(crc), 15);
        stream.bits + stream.stuffed + 13
    }
}

/// Counts the bits of a frame as the controller sends them: CRC-15 (polynomial 0x4599)
/// over the unstuffed bits, and the stuff bits the bit stuffing rule inserts.
#[derive(Default)]
struct BitStream {
    bits: u32,
    stuffed: u32,
    run_level: bool,
    run_len: u32,
    crc: u16,
}

impl BitStream {
    fn push(&mut self, value: u32, count: u32) {
        for i in (0..count).rev() {
            self.bit(value >> i & 1 != 0);
        }
    }

    fn bit(&mut self, level: bool) {
        // The CRC covers SOF .. data, not itself; once the 15 CRC bits are being pushed
        // the register is no longer read.
        let feedback = level ^ (self.crc >> 14 & 1 != 0);
        self.crc = (self.crc << 1) & 0x7FFF;
        if feedback {
            self.crc ^= 0x4599;
        }
        self.bits += 1;
        if self.run_len > 0 && level == self.run_level {
            self.run_len += 1;
        } else {
            self.run_level = level;
            self.run_len = 1;
        }
        if self.run_len == 5 {
            // A stuff bit of the opposite level, which starts a new run.
            self.stuffed += 1;
            self.run_level = !level;
            self.run_len = 1;
        }
    }
}

/// A COB-ID as the communication objects hold it (CiA 301 7.5.2: 0x1005, 0x1014,
/// 0x1400.., 0x1800..): bit 31 "not valid" (PDOs, EMCY), bit 30 "no RTR" (PDOs) or "SYNC
/// producer" (0x1005), bit 29 "29-bit frame", bits 10..0 the identifier.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CobId(pub u32);

impl CobId {
    /// Bit 31: the object does not exist / is not valid.
    pub const INVALID: u32 = 1 << 31;
    /// Bit 30: no RTR allowed on this PDO (PDO COB-IDs); the device produces SYNC (0x1005).
    pub const BIT30: u32 = 1 << 30;
    /// Bit 29: 29-bit identifier (extended frame).
    pub const EXTENDED: u32 = 1 << 29;

    /// A valid base-frame COB-ID.
    pub const fn new(id: u16) -> Self {
        Self(id as u32 & MAX_ID as u32)
    }

    /// The same identifier marked not valid.
    pub const fn invalid(self) -> Self {
        Self(self.0 | Self::INVALID)
    }

    /// True unless bit 31 is set.
    pub const fn is_valid(self) -> bool {
        self.0 & Self::INVALID == 0
    }

    /// The 11-bit identifier.
    pub const fn can_id(self) -> u16 {
        (self.0 & MAX_ID as u32) as u16
    }

    /// True if bit 29 is set or bits 28..11 are not zero: not a base-frame identifier.
    pub const fn is_extended(self) -> bool {
        self.0 & (Self::EXTENDED | 0x1FFF_F800) != 0
    }
}

/// CiA 301 7.3.5 "restricted CAN-IDs": identifiers a configurable COB-ID (PDO, EMCY, SYNC)
/// must not use, because the predefined connection set gives them to NMT, SYNC/EMCY of the
/// default ranges, SDO, NMT error control and LSS.
// Out of line (cold: parameter downloads): the SYNC, EMCY and PDO checks share one copy.
#[inline(never)]
pub fn is_restricted_id(id: u16) -> bool {
    // Ascending ranges: the search ends at the first one above `id`.
    RESTRICTED_IDS
        .iter()
        .take_while(|&&(first, _)| first <= id)
        .any(|&(_, last)| id <= last)
}

/// The restricted ranges of CiA 301 7.3.5 (first, last), in the order it lists them
/// (ascending).
const RESTRICTED_IDS: [(u16, u16); 8] = [
    (0x000, 0x000),
    (0x001, 0x07F),
    (0x101, 0x180),
    (0x581, 0x5FF),
    (0x601, 0x67F),
    (0x6E0, 0x6FF),
    (0x701, 0x77F),
    (0x780, 0x7FF),
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn data_and_remote_frames() {
        let f = CanFrame::new(0x601, &[0x40, 0x00, 0x10, 0x00]).unwrap();
        assert_eq!(f.id(), 0x601);
        assert_eq!(f.dlc(), 4);
        assert_eq!(f.data(), &[0x40, 0x00, 0x10, 0x00]);
        assert!(!f.is_remote());
        let r = CanFrame::remote(0x701, 1).unwrap();
        assert!(r.is_remote());
        assert_eq!(r.dlc(), 1);
        assert!(r.data().is_empty());
        assert_eq!(CanFrame::new(0x800, &[]), Err(FrameError::IdTooLarge));
        assert_eq!(CanFrame::new(1, &[0; 9]), Err(FrameError::TooLong));
        assert_eq!(CanFrame::remote(1, 9), Err(FrameError::TooLong));
    }

    #[test]
    fn frame_lengths_on_the_wire() {
        // Without stuffing an 8-byte frame is 44 + 64 + 3 + 7 = 111 bits with the
        // intermission; stuffing adds at most one bit per four after the first five.
        let f = CanFrame::new(0x555, &[0x55; 8]).unwrap();
        // Alternating bits need no stuffing in the identifier and data.
        let n = f.bits_on_wire();
        assert!((111..=114).contains(&n), "{n}");
        // All-zero data forces a stuff bit after every fifth bit.
        let zeros = CanFrame::new(0x000, &[0; 8]).unwrap().bits_on_wire();
        assert!(zeros >= 111 + 64 / 5, "{zeros}");
        // The worst case of ISO 11898-1: 34 + 8n stuffable bits, (34 + 8n - 1) / 4 stuff bits.
        assert!(zeros <= 111 + (34 + 64 - 1) / 4, "{zeros}");
        // A remote frame carries no data field.
        let r = CanFrame::remote(0x701, 1).unwrap().bits_on_wire();
        assert!((47..=47 + 8).contains(&r), "{r}");
    }

    #[test]
    fn crc15_of_a_known_frame() {
        // The CRC of SOF+ID+ctrl+data must make the register zero when its own 15 bits are
        // fed back in: check the register property rather than a copied vector.
        let mut s = BitStream::default();
        for (v, n) in [
            (0u32, 1u32),
            (0x123, 11),
            (0, 1),
            (0, 2),
            (2, 4),
            (0xAB, 8),
            (0xCD, 8),
        ] {
            s.push(v, n);
        }
        let crc = s.crc;
        s.push(u32::from(crc), 15);
        assert_eq!(s.crc, 0);
    }

    #[test]
    fn cob_id_bits() {
        let c = CobId::new(0x181);
        assert!(c.is_valid());
        assert_eq!(c.can_id(), 0x181);
        let off = c.invalid();
        assert!(!off.is_valid());
        assert_eq!(off.0, 0x8000_0181);
        assert!(CobId(0x2000_0181).is_extended());
        assert!(CobId(0x0000_0800).is_extended());
        assert!(!CobId(0xC000_0181).is_extended());
    }

    #[test]
    fn restricted_ids() {
        for id in [
            0x000, 0x001, 0x07F, 0x101, 0x180, 0x581, 0x601, 0x6E0, 0x701, 0x7FF,
        ] {
            assert!(is_restricted_id(id), "{id:#x}");
        }
        for id in [
            0x080, 0x100, 0x181, 0x1FF, 0x200, 0x480, 0x57F, 0x580, 0x680, 0x700,
        ] {
            assert!(!is_restricted_id(id), "{id:#x}");
        }
    }
}
