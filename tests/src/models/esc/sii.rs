//! The SII EEPROM interface 0x0500..0x050F (ESC datasheet Section I ch. 11, Section II
//! 0x0500) and the configuration loaded from SII words 0..7 at power-up.

use super::{regs, Esc, Side};

/// The CRC of SII word 7: polynomial 0x07, init 0xFF, MSB first, no reflection, no final
/// XOR. The model computes it from its own parameters, not with `coe_core::sii::crc8`: the
/// SII generator's checksum is one of the things the model checks.
pub const SII_CRC: crc::Algorithm<u8> = crc::Algorithm {
    width: 8,
    poly: 0x07,
    init: 0xFF,
    refin: false,
    refout: false,
    xorout: 0x00,
    check: 0xFB,
    residue: 0x00,
};

/// CRC-8 of SII word 7 over the 14 bytes of words 0..6.
pub fn sii_crc8(bytes: &[u8]) -> u8 {
    crc::Crc::<u8>::new(&SII_CRC).checksum(bytes)
}

/// Why the configuration area of an SII image was not accepted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SiiConfigError {
    /// The image is shorter than the 16-byte configuration area.
    TooShort,
    /// Word 7's low byte does not match the CRC of words 0..6.
    Checksum {
        /// CRC computed over words 0..6.
        computed: u8,
        /// CRC stored in word 7.
        stored: u8,
    },
}

/// Checks the configuration-area checksum of an SII image.
pub fn check_config_area(image: &[u8]) -> Result<(), SiiConfigError> {
    if image.len() < 16 {
        return Err(SiiConfigError::TooShort);
    }
    let computed = sii_crc8(&image[..14]);
    let stored = image[14];
    if computed == stored {
        Ok(())
    } else {
        Err(SiiConfigError::Checksum { computed, stored })
    }
}

pub(super) struct SiiState {
    pub image: Vec<u8>,
    pub loaded_ok: bool,
    /// Command in progress and the virtual time it completes.
    pub busy: Option<(u8, u64)>,
}

impl SiiState {
    pub fn new(image: Vec<u8>) -> Self {
        Self {
            image,
            loaded_ok: false,
            busy: None,
        }
    }

    fn word(&self, w: u32) -> [u8; 2] {
        let i = w as usize * 2;
        [
            self.image.get(i).copied().unwrap_or(0xFF),
            self.image.get(i + 1).copied().unwrap_or(0xFF),
        ]
    }
}

impl Esc {
    /// The SII EEPROM image as it currently is (writes included).
    pub fn sii_image(&self) -> &[u8] {
        &self.sii.image
    }

    /// The side that owns the EEPROM interface: ECAT unless 0x0500 b0 offers it to the
    /// PDI and 0x0501 b0 shows the PDI took it (0x0500 b1 forces ECAT).
    pub(super) fn sii_owner(&self) -> Side {
        let cfg = self.peek_u8(regs::EEPROM_CONFIG);
        let pdi = self.peek_u8(regs::EEPROM_PDI_ACCESS);
        if cfg & 0x02 == 0 && cfg & 0x01 != 0 && pdi & 0x01 != 0 {
            Side::Pdi
        } else {
            Side::Ecat
        }
    }

    /// Power-up with a loading time: the EEPROM interface is busy with a reload command
    /// (0x0502 b15, b12 "not loaded") until `ns` have passed, then the configuration loads.
    pub(super) fn sii_start_loading(&mut self, ns: u64) {
        self.sii.loaded_ok = false;
        let ctl = self.peek_u16(regs::EEPROM_CONTROL) | 0x8000 | 0x1000 | 0x0400;
        self.set_u16(regs::EEPROM_CONTROL, ctl);
        self.sii.busy = Some((4, self.now_ns + ns));
    }

    /// Loads words 0..7 into the registers (power-up and reload command). A failed load
    /// sets b11 (checksum error) and b12 (EEPROM not loaded, device information not
    /// available).
    pub(super) fn sii_load_config(&mut self) {
        let ok = check_config_area(&self.sii.image).is_ok();
        self.sii.loaded_ok = ok;
        let mut ctl = self.peek_u16(regs::EEPROM_CONTROL) & !(0x1800);
        // b6: 8-byte reads (ET1100); b7: 2-byte addressing for EEPROMs > 16 Kbit.
        ctl &= !0x00C0;
        if self.cfg.eeprom_read_8 {
            ctl |= 0x0040;
        }
        if self.sii.image.len() > 2048 {
            ctl |= 0x0080;
        }
        if ok {
            let w = |i: u32| u16::from_le_bytes(self.sii.word(i));
            let (w0, w1, w2, w3, w4) = (w(0), w(1), w(2), w(3), w(4));
            self.set_u16(regs::PDI_CONTROL, w0);
            self.set_u16(regs::PDI_CONFIG, w1);
            self.set_u16(regs::DC_PULSE_LENGTH, w2);
            self.set_u16(0x0152, w3);
            self.set_u16(regs::STATION_ALIAS, w4);
        } else {
            // Checksum error; the PDI is not operational.
            ctl |= 0x0800 | 0x1000;
            self.set_u16(regs::PDI_CONTROL, 0);
            self.set_u16(regs::PDI_CONFIG, 0);
        }
        self.set_u16(regs::EEPROM_CONTROL, ctl);
        self.update_dl_status();
    }

    /// A write to 0x0503 (command bits) by `side` finished.
    pub(super) fn sii_command(&mut self, _side: Side) {
        let ctl = self.peek_u16(regs::EEPROM_CONTROL);
        let cmd = ((ctl >> 8) & 0x07) as u8;
        // Any command write clears the command and write-enable error bits.
        let mut ctl = ctl & !(0x6000);
        if cmd == 0 {
            self.set_u16(regs::EEPROM_CONTROL, ctl);
            return;
        }
        if self.sii.busy.is_some() || !matches!(cmd, 1 | 2 | 4) {
            // Busy or several command bits at once: command error.
            ctl = (ctl & !0x0700) | 0x2000;
            if let Some((c, _)) = self.sii.busy {
                ctl |= (c as u16) << 8;
            }
            self.set_u16(regs::EEPROM_CONTROL, ctl);
            return;
        }
        if cmd == 2 && ctl & 0x0001 == 0 {
            // Write without write enable.
            ctl = (ctl & !0x0700) | 0x4000;
            self.set_u16(regs::EEPROM_CONTROL, ctl);
            return;
        }
        ctl |= 0x8000;
        self.set_u16(regs::EEPROM_CONTROL, ctl);
        self.sii.busy = Some((cmd, self.now_ns + self.cfg.eeprom_busy_ns));
    }

    /// Completes a pending EEPROM command when its time has come.
    pub(super) fn sii_update(&mut self) {
        let Some((cmd, done)) = self.sii.busy else {
            return;
        };
        if self.now_ns < done {
            return;
        }
        self.sii.busy = None;
        let addr = self.peek_u32(regs::EEPROM_ADDRESS);
        match cmd {
            1 => {
                let words = if self.cfg.eeprom_read_8 { 4 } else { 2 };
                let mut data = [0u8; 8];
                self.peek(regs::EEPROM_DATA, &mut data);
                for i in 0..words {
                    let w = self.sii.word(addr.wrapping_add(i));
                    data[i as usize * 2..i as usize * 2 + 2].copy_from_slice(&w);
                }
                self.poke(regs::EEPROM_DATA, &data);
            }
            2 => {
                let mut d = [0u8; 2];
                self.peek(regs::EEPROM_DATA, &mut d);
                let i = addr as usize * 2;
                if i + 1 < self.sii.image.len() {
                    self.sii.image[i..i + 2].copy_from_slice(&d);
                }
            }
            4 => self.sii_load_config(),
            _ => {}
        }
        // Clear busy, the command bits and write enable.
        let ctl = self.peek_u16(regs::EEPROM_CONTROL) & !(0x8000 | 0x0700 | 0x0001);
        self.set_u16(regs::EEPROM_CONTROL, ctl);
    }
}
