//! CoE header (ETG.1000.6 5.6.1 "CoE header" and its list of CoE services).
//!
//! ```text
//!  byte 0..2  u16 LE: number [8:0] | reserved [11:9] | service [15:12]
//!  byte 2..   service data (SDO, SDO Information, Emergency, PDO)
//! ```

use super::{get_u16, need, set_u16, tail, tail_mut, Error, Result};

mod field {
    use core::ops::Range;

    pub const NUMBER_SERVICE: Range<usize> = 0..2;
    pub const PAYLOAD: usize = 2;
}

/// Length of the CoE header.
pub const HEADER_LEN: usize = field::PAYLOAD;

crate::open_enum! {
    /// CoE service (header bits 15:12), ETG.1000.6 5.6.1.
    pub enum CoeService(u8) {
        /// Emergency.
        Emergency = 1,
        /// SDO request (also used for an SDO abort in either direction).
        SdoRequest = 2,
        /// SDO response.
        SdoResponse = 3,
        /// TxPDO.
        TxPdo = 4,
        /// RxPDO.
        RxPdo = 5,
        /// TxPDO remote request.
        TxPdoRemoteRequest = 6,
        /// RxPDO remote request.
        RxPdoRemoteRequest = 7,
        /// SDO Information.
        SdoInformation = 8,
    }
}

/// A read/write view of a CoE frame (the mailbox payload of a CoE mailbox frame).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Coe<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> Coe<T> {
    /// Wraps a buffer without checking it (for emitting).
    pub const fn new_unchecked(buffer: T) -> Coe<T> {
        Coe { buffer }
    }

    /// Wraps a buffer and checks it with [`check_len`](Self::check_len).
    pub fn new_checked(buffer: T) -> Result<Coe<T>> {
        let packet = Self::new_unchecked(buffer);
        packet.check_len()?;
        Ok(packet)
    }

    /// `Err(Truncated)` if the buffer is shorter than the 2-byte header.
    pub fn check_len(&self) -> Result<()> {
        need(self.buffer.as_ref().len(), HEADER_LEN)
    }

    /// Gives the buffer back.
    pub fn into_inner(self) -> T {
        self.buffer
    }

    /// Number (bits 8:0; the PDO number for PDO services, 0 otherwise).
    pub fn number(&self) -> u16 {
        get_u16(self.buffer.as_ref(), field::NUMBER_SERVICE) & 0x01FF
    }

    /// Reserved bits 11:9.
    pub fn reserved(&self) -> u8 {
        ((get_u16(self.buffer.as_ref(), field::NUMBER_SERVICE) >> 9) & 0x07) as u8
    }

    /// Service (bits 15:12).
    pub fn service(&self) -> CoeService {
        CoeService::from((get_u16(self.buffer.as_ref(), field::NUMBER_SERVICE) >> 12) as u8)
    }
}

impl<'a, T: AsRef<[u8]> + ?Sized> Coe<&'a T> {
    /// The service data after the header.
    pub fn payload(&self) -> &'a [u8] {
        tail(self.buffer.as_ref(), HEADER_LEN)
    }
}

impl<T: AsRef<[u8]> + AsMut<[u8]>> Coe<T> {
    fn set_word(&mut self, mask: u16, bits: u16) {
        let data = self.buffer.as_mut();
        let w = get_u16(data, field::NUMBER_SERVICE);
        set_u16(data, field::NUMBER_SERVICE, (w & !mask) | (bits & mask));
    }

    /// Sets the number (9 bits; higher bits are dropped).
    pub fn set_number(&mut self, value: u16) {
        self.set_word(0x01FF, value)
    }

    /// Sets the reserved bits (3 bits; higher bits are dropped).
    pub fn set_reserved(&mut self, value: u8) {
        self.set_word(0x0E00, u16::from(value) << 9)
    }

    /// Sets the service (4 bits; higher bits are dropped).
    pub fn set_service(&mut self, value: CoeService) {
        self.set_word(0xF000, u16::from(u8::from(value)) << 12)
    }

    /// The service data after the header.
    pub fn payload_mut(&mut self) -> &mut [u8] {
        tail_mut(self.buffer.as_mut(), HEADER_LEN)
    }
}

/// A CoE header as values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CoeRepr {
    /// Number, 0..=0x1FF (0 for SDO, SDO Information and Emergency).
    pub number: u16,
    /// Service.
    pub service: CoeService,
}

impl CoeRepr {
    /// A header for `service` with number 0.
    pub const fn new(service: CoeService) -> CoeRepr {
        CoeRepr { number: 0, service }
    }

    /// Parses a CoE header. The reserved bits are ignored.
    pub fn parse<T: AsRef<[u8]> + ?Sized>(packet: &Coe<&T>) -> Result<CoeRepr> {
        packet.check_len()?;
        Ok(CoeRepr {
            number: packet.number(),
            service: packet.service(),
        })
    }

    /// Always 2 (the header alone).
    pub const fn buffer_len(&self) -> usize {
        HEADER_LEN
    }

    /// Writes the header (reserved bits 0). `Err(Malformed)` for a number above 0x1FF or a
    /// service above 15.
    pub fn emit<T: AsRef<[u8]> + AsMut<[u8]>>(&self, packet: &mut Coe<T>) -> Result<()> {
        if self.number > 0x01FF || u8::from(self.service) > 0x0F {
            return Err(Error::Malformed);
        }
        need(packet.buffer.as_ref().len(), HEADER_LEN)?;
        packet.set_number(self.number);
        packet.set_reserved(0);
        packet.set_service(self.service);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// CoE header of an SDO request (service 2, number 0) followed by an upload request.
    static SDO_REQUEST_BYTES: [u8; 10] =
        [0x00, 0x20, 0x40, 0x00, 0x10, 0x00, 0x00, 0x00, 0x00, 0x00];

    /// RxPDO (service 5) number 0x1AB with reserved bits 0: 0x51AB.
    static PDO_HEADER: [u8; 2] = [0xAB, 0x51];

    #[test]
    fn deconstruct() {
        let packet = Coe::new_checked(&SDO_REQUEST_BYTES[..]).unwrap();
        assert_eq!(packet.number(), 0);
        assert_eq!(packet.reserved(), 0);
        assert_eq!(packet.service(), CoeService::SdoRequest);
        assert_eq!(packet.payload(), &SDO_REQUEST_BYTES[2..]);

        let packet = Coe::new_checked(&PDO_HEADER[..]).unwrap();
        assert_eq!(packet.number(), 0x1AB);
        assert_eq!(packet.service(), CoeService::RxPdo);
        assert_eq!(packet.payload(), &[] as &[u8]);
    }

    #[test]
    fn deconstruct_reserved() {
        let bytes = [0x00, 0x8E];
        let packet = Coe::new_checked(&bytes[..]).unwrap();
        assert_eq!(packet.reserved(), 7);
        assert_eq!(packet.number(), 0);
        assert_eq!(packet.service(), CoeService::SdoInformation);
    }

    #[test]
    fn construct() {
        let mut bytes = [0xa5u8; 2];
        let mut packet = Coe::new_unchecked(&mut bytes[..]);
        packet.set_number(0x1AB);
        packet.set_reserved(0);
        packet.set_service(CoeService::RxPdo);
        assert_eq!(bytes, PDO_HEADER);
    }

    #[test]
    fn parse_emit() {
        let r = CoeRepr::parse(&Coe::new_unchecked(&SDO_REQUEST_BYTES[..])).unwrap();
        assert_eq!(r, CoeRepr::new(CoeService::SdoRequest));
        let mut bytes = [0xa5u8; 10];
        let mut packet = Coe::new_unchecked(&mut bytes[..]);
        r.emit(&mut packet).unwrap();
        packet
            .payload_mut()
            .copy_from_slice(&SDO_REQUEST_BYTES[2..]);
        assert_eq!(bytes, SDO_REQUEST_BYTES);

        let r = CoeRepr {
            number: 0x1AB,
            service: CoeService::RxPdo,
        };
        let mut bytes = [0xa5u8; 2];
        r.emit(&mut Coe::new_unchecked(&mut bytes[..])).unwrap();
        assert_eq!(bytes, PDO_HEADER);
    }

    #[test]
    fn services() {
        let table: [(u8, CoeService, [u8; 2]); 8] = [
            (1, CoeService::Emergency, [0x00, 0x10]),
            (2, CoeService::SdoRequest, [0x00, 0x20]),
            (3, CoeService::SdoResponse, [0x00, 0x30]),
            (4, CoeService::TxPdo, [0x00, 0x40]),
            (5, CoeService::RxPdo, [0x00, 0x50]),
            (6, CoeService::TxPdoRemoteRequest, [0x00, 0x60]),
            (7, CoeService::RxPdoRemoteRequest, [0x00, 0x70]),
            (8, CoeService::SdoInformation, [0x00, 0x80]),
        ];
        for (raw, service, bytes) in table {
            assert_eq!(CoeService::from(raw), service);
            assert_eq!(Coe::new_unchecked(&bytes[..]).service(), service);
            let mut out = [0xa5u8; 2];
            CoeRepr::new(service)
                .emit(&mut Coe::new_unchecked(&mut out[..]))
                .unwrap();
            assert_eq!(out, bytes);
        }
        assert_eq!(
            Coe::new_unchecked(&[0x00u8, 0x00][..]).service(),
            CoeService::Unknown(0)
        );
        assert_eq!(
            Coe::new_unchecked(&[0x00u8, 0xF0][..]).service(),
            CoeService::Unknown(15)
        );
    }

    #[test]
    fn truncated() {
        assert_eq!(
            Coe::new_checked(&SDO_REQUEST_BYTES[..1]),
            Err(Error::Truncated)
        );
        assert_eq!(
            CoeRepr::parse(&Coe::new_unchecked(&[][..])),
            Err(Error::Truncated)
        );
        assert_eq!(Coe::new_unchecked(&[0x12u8][..]).number(), 0);
        let mut one = [0u8; 1];
        assert_eq!(
            CoeRepr::new(CoeService::SdoRequest).emit(&mut Coe::new_unchecked(&mut one[..])),
            Err(Error::Truncated)
        );
    }

    #[test]
    fn out_of_range() {
        let mut bytes = [0u8; 2];
        let bad = CoeRepr {
            number: 0x200,
            service: CoeService::SdoRequest,
        };
        assert_eq!(
            bad.emit(&mut Coe::new_unchecked(&mut bytes[..])),
            Err(Error::Malformed)
        );
        let bad = CoeRepr::new(CoeService::Unknown(16));
        assert_eq!(
            bad.emit(&mut Coe::new_unchecked(&mut bytes[..])),
            Err(Error::Malformed)
        );
    }
}
