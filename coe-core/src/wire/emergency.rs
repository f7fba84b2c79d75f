//! CoE Emergency (ETG.1000.6 5.6.4 "Emergency"; CiA 301 7.2.7 EMCY).
//!
//! The view starts after the CoE header (service 1, number 0); the mailbox length is 10.
//!
//! ```text
//!  byte 0..2  error code u16 (CiA 301 EMCY error codes; 0x0000 = error reset)
//!  byte 2     error register u8 (object 0x1001)
//!  byte 3..8  manufacturer / diagnostic data, 5 bytes
//! ```

use super::{get_u16, get_u8, need, set_bytes, set_u16, set_u8, tail, Result};

mod field {
    use core::ops::Range;

    pub const ERROR_CODE: Range<usize> = 0..2;
    pub const ERROR_REGISTER: usize = 2;
    pub const DATA: Range<usize> = 3..8;
}

/// Length of an emergency after the CoE header.
pub const LEN: usize = field::DATA.end;

/// Mailbox length of an emergency frame (CoE header + 8).
pub const MAILBOX_LEN: usize = super::coe::HEADER_LEN + LEN;

/// A read/write view of an emergency (the bytes after the CoE header).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Emergency<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> Emergency<T> {
    /// Wraps a buffer without checking it (for emitting).
    pub const fn new_unchecked(buffer: T) -> Emergency<T> {
        Emergency { buffer }
    }

    /// Wraps a buffer and checks it with [`check_len`](Self::check_len).
    pub fn new_checked(buffer: T) -> Result<Emergency<T>> {
        let packet = Self::new_unchecked(buffer);
        packet.check_len()?;
        Ok(packet)
    }

    /// `Err(Truncated)` if the buffer is shorter than 8 bytes.
    pub fn check_len(&self) -> Result<()> {
        need(self.buffer.as_ref().len(), LEN)
    }

    /// Gives the buffer back.
    pub fn into_inner(self) -> T {
        self.buffer
    }

    /// Error code.
    pub fn error_code(&self) -> u16 {
        get_u16(self.buffer.as_ref(), field::ERROR_CODE)
    }

    /// Error register (0x1001).
    pub fn error_register(&self) -> u8 {
        get_u8(self.buffer.as_ref(), field::ERROR_REGISTER)
    }

    /// The 5 data bytes (zeros outside an unchecked buffer).
    pub fn data(&self) -> [u8; 5] {
        let mut out = [0u8; 5];
        let src = tail(self.buffer.as_ref(), field::DATA.start);
        set_bytes(&mut out, 0, src);
        out
    }
}

impl<T: AsRef<[u8]> + AsMut<[u8]>> Emergency<T> {
    /// Sets the error code.
    pub fn set_error_code(&mut self, value: u16) {
        set_u16(self.buffer.as_mut(), field::ERROR_CODE, value)
    }

    /// Sets the error register.
    pub fn set_error_register(&mut self, value: u8) {
        set_u8(self.buffer.as_mut(), field::ERROR_REGISTER, value)
    }

    /// Sets the 5 data bytes.
    pub fn set_data(&mut self, value: [u8; 5]) {
        if let Some(dst) = self.buffer.as_mut().get_mut(field::DATA) {
            set_bytes(dst, 0, &value);
        }
    }
}

/// An emergency as values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EmergencyRepr {
    /// Error code (0x0000 = error reset / no error).
    pub error_code: u16,
    /// Error register (0x1001).
    pub error_register: u8,
    /// Manufacturer-specific data.
    pub data: [u8; 5],
}

impl EmergencyRepr {
    /// Parses an emergency; bytes after the 8th are ignored.
    pub fn parse<T: AsRef<[u8]> + ?Sized>(packet: &Emergency<&T>) -> Result<EmergencyRepr> {
        packet.check_len()?;
        Ok(EmergencyRepr {
            error_code: packet.error_code(),
            error_register: packet.error_register(),
            data: packet.data(),
        })
    }

    /// Always 8.
    pub const fn buffer_len(&self) -> usize {
        LEN
    }

    /// Writes the emergency.
    pub fn emit<T: AsRef<[u8]> + AsMut<[u8]>>(&self, packet: &mut Emergency<T>) -> Result<()> {
        need(packet.buffer.as_ref().len(), LEN)?;
        packet.set_error_code(self.error_code);
        packet.set_error_register(self.error_register);
        packet.set_data(self.data);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wire::{Coe, CoeRepr, CoeService, Error, Mailbox, MailboxRepr, MailboxType};

    /// Whole mailbox frame of an emergency: length 10, CoE type, counter 3; CoE header
    /// service 1; error code 0x8700, error register 0x11
    /// (generic + communication), data 01 02 03 04 05.
    static FRAME: [u8; 16] = [
        0x0A, 0x00, 0x00, 0x00, 0x00, 0x33, // mailbox header
        0x00, 0x10, // CoE header: emergency
        0x00, 0x87, 0x11, 0x01, 0x02, 0x03, 0x04, 0x05,
    ];

    fn repr() -> EmergencyRepr {
        EmergencyRepr {
            error_code: 0x8700,
            error_register: 0x11,
            data: [1, 2, 3, 4, 5],
        }
    }

    #[test]
    fn deconstruct() {
        let p = Emergency::new_checked(&FRAME[8..]).unwrap();
        assert_eq!(p.error_code(), 0x8700);
        assert_eq!(p.error_register(), 0x11);
        assert_eq!(p.data(), [1, 2, 3, 4, 5]);
    }

    #[test]
    fn construct() {
        let mut bytes = [0xa5u8; 8];
        let mut p = Emergency::new_unchecked(&mut bytes[..]);
        p.set_error_code(0x8700);
        p.set_error_register(0x11);
        p.set_data([1, 2, 3, 4, 5]);
        assert_eq!(bytes, FRAME[8..]);
    }

    #[test]
    fn parse_emit() {
        assert_eq!(
            EmergencyRepr::parse(&Emergency::new_unchecked(&FRAME[8..])),
            Ok(repr())
        );
        let mut bytes = [0xa5u8; 9];
        repr()
            .emit(&mut Emergency::new_unchecked(&mut bytes[..]))
            .unwrap();
        assert_eq!(bytes[..8], FRAME[8..]);
        assert_eq!(bytes[8], 0xa5);
        assert_eq!(repr().buffer_len(), 8);
    }

    #[test]
    fn whole_frame_through_the_layers() {
        let mut bytes = [0xa5u8; 16];
        let header = MailboxRepr {
            address: 0,
            channel: 0,
            priority: 0,
            mailbox_type: MailboxType::Coe,
            counter: 3,
            payload_len: MAILBOX_LEN,
        };
        let mut mbx = Mailbox::new_unchecked(&mut bytes[..]);
        header.emit(&mut mbx).unwrap();
        let mut coe = Coe::new_unchecked(mbx.payload_mut());
        CoeRepr::new(CoeService::Emergency).emit(&mut coe).unwrap();
        repr()
            .emit(&mut Emergency::new_unchecked(coe.payload_mut()))
            .unwrap();
        assert_eq!(bytes, FRAME);

        let mbx = Mailbox::new_checked(&FRAME[..]).unwrap();
        let coe = Coe::new_checked(mbx.payload()).unwrap();
        assert_eq!(coe.service(), CoeService::Emergency);
        assert_eq!(
            EmergencyRepr::parse(&Emergency::new_unchecked(coe.payload())),
            Ok(repr())
        );
    }

    #[test]
    fn truncated() {
        for n in 0..LEN {
            assert_eq!(
                Emergency::new_checked(&FRAME[8..8 + n]),
                Err(Error::Truncated)
            );
        }
        assert_eq!(Emergency::new_unchecked(&FRAME[8..11]).data(), [0; 5]);
        let mut short = [0u8; 7];
        assert_eq!(
            repr().emit(&mut Emergency::new_unchecked(&mut short[..])),
            Err(Error::Truncated)
        );
    }
}
