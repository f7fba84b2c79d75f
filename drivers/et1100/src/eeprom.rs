//! EEPROM (SII) access from the PDI (0x0500..0x050F; ESC-I 11, ESC-II 2.11;
//! hardware-facts 1.4).
//!
//! The master offers the EEPROM to the PDI with 0x0500 b0; the PDI takes it by writing
//! 0x0501 = 1 ([`Et1100::eeprom_take`]) and gives it back with 0x0501 = 0
//! ([`Et1100::eeprom_release`]). A read writes the word address (0x0504), then the read
//! command (0x0502 bits 10:8 = 1), polls the busy bit (0x0502 b15) at most `max_polls` times
//! and reads 4 or 8 bytes from 0x0508 (0x0502 b6).

use crate::{Error, Et1100, Pdi, Register};

/// EEPROM control/status register (0x0502, u16).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EepromStatus(pub u16);

impl EepromStatus {
    /// b11 checksum error, b13 acknowledge/command error, b14 write enable error.
    pub const ERROR_MASK: u16 = (1 << 11) | (1 << 13) | (1 << 14);

    /// The raw value.
    pub const fn bits(self) -> u16 {
        self.0
    }

    /// b0: write enable.
    pub const fn write_enable(self) -> bool {
        self.0 & (1 << 0) != 0
    }

    /// b5: EEPROM emulation (the PDI serves the EEPROM commands).
    pub const fn emulation(self) -> bool {
        self.0 & (1 << 5) != 0
    }

    /// b6: a read returns 8 bytes (else 4).
    pub const fn read_8_bytes(self) -> bool {
        self.0 & (1 << 6) != 0
    }

    /// Bytes delivered per read command: 8 or 4 (b6).
    pub const fn read_size(self) -> usize {
        if self.read_8_bytes() {
            8
        } else {
            4
        }
    }

    /// b7: 2 address bytes (EEPROM > 16 kbit).
    pub const fn two_address_bytes(self) -> bool {
        self.0 & (1 << 7) != 0
    }

    /// Bits 10:8: the command register.
    pub const fn command(self) -> u8 {
        ((self.0 >> 8) & 0x07) as u8
    }

    /// b11: checksum error in the ESC configuration area.
    pub const fn checksum_error(self) -> bool {
        self.0 & (1 << 11) != 0
    }

    /// b12: device information not loaded.
    pub const fn not_loaded(self) -> bool {
        self.0 & (1 << 12) != 0
    }

    /// b13: missing acknowledge or invalid command.
    pub const fn ack_error(self) -> bool {
        self.0 & (1 << 13) != 0
    }

    /// b14: write without write enable.
    pub const fn write_enable_error(self) -> bool {
        self.0 & (1 << 14) != 0
    }

    /// b15: busy.
    pub const fn busy(self) -> bool {
        self.0 & (1 << 15) != 0
    }

    /// Any of b11, b13, b14.
    pub const fn has_error(self) -> bool {
        self.0 & Self::ERROR_MASK != 0
    }
}

/// One EEPROM read result: 4 or 8 bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EepromChunk {
    data: [u8; 8],
    len: u8,
}

impl EepromChunk {
    /// The bytes read (4 or 8).
    pub fn as_bytes(&self) -> &[u8] {
        self.data.get(..usize::from(self.len)).unwrap_or(&[])
    }
}

/// Command "read" in 0x0502 bits 10:8.
const CMD_READ: u16 = 0x0100;

impl<P: Pdi> Et1100<P> {
    /// Takes the EEPROM for the PDI: checks 0x0500 (b0 offered, b1 not forced to ECAT) and
    /// writes 0x0501 = 1.
    pub fn eeprom_take(&mut self) -> Result<(), Error<P::BusError>> {
        let cfg = self.read_u8(Register::EepromConfiguration)?;
        if cfg & 0x01 == 0 || cfg & 0x02 != 0 {
            return Err(Error::EepromNotOffered);
        }
        self.write(Register::EepromPdiAccess.addr(), &[0x01])?;
        Ok(())
    }

    /// Gives the EEPROM back to ECAT (0x0501 = 0).
    pub fn eeprom_release(&mut self) -> Result<(), Error<P::BusError>> {
        self.write(Register::EepromPdiAccess.addr(), &[0x00])?;
        Ok(())
    }

    /// EEPROM control/status (0x0502).
    pub fn eeprom_status(&mut self) -> Result<EepromStatus, Error<P::BusError>> {
        self.read_u16(Register::EepromControlStatus)
            .map(EepromStatus)
    }

    /// Polls 0x0502 until not busy, at most `max_polls` reads; errors on b11/b13/b14.
    fn eeprom_wait(&mut self, max_polls: u32) -> Result<EepromStatus, Error<P::BusError>> {
        for _ in 0..max_polls {
            let s = self.eeprom_status()?;
            if !s.busy() {
                if s.has_error() {
                    return Err(Error::Eeprom(s));
                }
                return Ok(s);
            }
        }
        Err(Error::Timeout)
    }

    /// Reads one chunk (4 or 8 bytes, 0x0502 b6) at the EEPROM word address `word`.
    ///
    /// Polls the busy bit at most `max_polls` times before the command and again after it
    /// (each poll is one PDI access); [`Error::Timeout`] when it stays busy. The EEPROM must
    /// have been taken with [`Et1100::eeprom_take`].
    pub fn eeprom_read_chunk(
        &mut self,
        word: u32,
        max_polls: u32,
    ) -> Result<EepromChunk, Error<P::BusError>> {
        self.eeprom_wait(max_polls)?;
        self.write(Register::EepromAddress.addr(), &word.to_le_bytes())?;
        self.write(
            Register::EepromControlStatus.addr(),
            &CMD_READ.to_le_bytes(),
        )?;
        let status = self.eeprom_wait(max_polls)?;
        let mut chunk = EepromChunk {
            data: [0; 8],
            len: if status.read_8_bytes() { 8 } else { 4 },
        };
        let n = usize::from(chunk.len);
        if let Some(dst) = chunk.data.get_mut(..n) {
            self.read(Register::EepromData.addr(), dst)?;
        }
        Ok(chunk)
    }

    /// Fills `buf` from the EEPROM starting at word address `word`, chunk by chunk (see
    /// [`Et1100::eeprom_read_chunk`]; `max_polls` applies to each wait).
    pub fn eeprom_read(
        &mut self,
        word: u32,
        buf: &mut [u8],
        max_polls: u32,
    ) -> Result<(), Error<P::BusError>> {
        let mut word = word;
        let mut done = 0usize;
        while done < buf.len() {
            let chunk = self.eeprom_read_chunk(word, max_polls)?;
            let bytes = chunk.as_bytes();
            let n = bytes.len().min(buf.len() - done);
            if let (Some(dst), Some(src)) = (buf.get_mut(done..done + n), bytes.get(..n)) {
                dst.copy_from_slice(src);
            }
            done += n;
            if done < buf.len() {
                // 2 bytes per word.
                word = word
                    .checked_add((bytes.len() / 2) as u32)
                    .ok_or(Error::OutOfRange)?;
            }
        }
        Ok(())
    }
}
