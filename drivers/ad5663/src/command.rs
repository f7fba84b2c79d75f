//! The 24-bit input shift register word (AD5663 datasheet p. 16, AD5663R p. 21, Table 8/9).
//!
//! ```text
//!  DB23 DB22 | DB21 DB20 DB19 | DB18 DB17 DB16 | DB15 .............. DB0
//!   x    x   |  C2   C1   C0  |  A2   A1   A0  | data (16 bits, MSB first)
//! ```
//! Sent MSB first in one SYNC-low frame; the command executes on the 24th falling SCLK edge.

use crate::types::{Channel, LdacMask, PowerMode, ResetMode};
use crate::unconfirmed;

/// One command of the AD5663 command set.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Command {
    /// 000: write input register n.
    WriteInput(Channel, u16),
    /// 001: update DAC register n (from its input register).
    UpdateDac(Channel),
    /// 010: write input register n, update all DAC registers (software LDAC).
    WriteInputUpdateAll(Channel, u16),
    /// 011: write to and update DAC channel n.
    WriteAndUpdate(Channel, u16),
    /// 100: power mode (DB5:4) for the channels selected by DB1 (B) / DB0 (A).
    PowerMode(Channel, PowerMode),
    /// 101: software reset (DB0 selects the extent).
    Reset(ResetMode),
    /// 110: LDAC register setup (DB1 = B, DB0 = A; 1 = transparent).
    LdacSetup(LdacMask),
    /// 111: internal reference on (DB0 = 1) / off. AD5663R only; reserved on the AD5663.
    InternalReference(bool),
}

impl Command {
    /// Command bits C2..C0.
    const fn code(self) -> u32 {
        match self {
            Command::WriteInput(..) => 0b000,
            Command::UpdateDac(_) => 0b001,
            Command::WriteInputUpdateAll(..) => 0b010,
            Command::WriteAndUpdate(..) => 0b011,
            Command::PowerMode(..) => 0b100,
            Command::Reset(_) => 0b101,
            Command::LdacSetup(_) => 0b110,
            Command::InternalReference(_) => 0b111,
        }
    }

    /// Address bits A2..A0 (000 where the command has no address: don't care).
    const fn address(self) -> u32 {
        match self {
            Command::WriteInput(c, _)
            | Command::UpdateDac(c)
            | Command::WriteInputUpdateAll(c, _)
            | Command::WriteAndUpdate(c, _) => c.address() as u32,
            _ => 0,
        }
    }

    /// Data bits DB15..DB0.
    const fn data(self) -> u16 {
        match self {
            Command::WriteInput(_, d)
            | Command::WriteInputUpdateAll(_, d)
            | Command::WriteAndUpdate(_, d) => d,
            Command::UpdateDac(_) => 0,
            Command::PowerMode(c, m) => (m.bits() << 4) | c.select_bits(),
            Command::Reset(ResetMode::DacAndInputRegisters) => 0,
            Command::Reset(ResetMode::All) => unconfirmed::FULL_RESET_DB0,
            Command::LdacSetup(m) => m.bits(),
            Command::InternalReference(on) => on as u16,
        }
    }

    /// The 24-bit word (DB23..DB22 sent as 0).
    pub(crate) const fn bits(self) -> u32 {
        (self.code() << 19) | (self.address() << 16) | self.data() as u32
    }

    /// The word as the three bytes of the frame, MSB first.
    pub(crate) const fn bytes(self) -> [u8; 3] {
        let w = self.bits();
        [(w >> 16) as u8, (w >> 8) as u8, w as u8]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    macro_rules! word {
        ($name:ident, $cmd:expr, $bits:expr) => {
            #[test]
            fn $name() {
                let c = $cmd;
                assert_eq!(c.bits(), $bits);
                let b: u32 = $bits;
                assert_eq!(c.bytes(), [(b >> 16) as u8, (b >> 8) as u8, b as u8]);
            }
        };
    }

    word!(
        write_input_a,
        Command::WriteInput(Channel::A, 0x1234),
        0x00_1234
    );
    word!(
        write_input_b,
        Command::WriteInput(Channel::B, 0xFFFF),
        0x01_FFFF
    );
    word!(
        write_input_both,
        Command::WriteInput(Channel::Both, 0x8000),
        0x07_8000
    );
    word!(update_dac_a, Command::UpdateDac(Channel::A), 0x08_0000);
    word!(update_dac_b, Command::UpdateDac(Channel::B), 0x09_0000);
    word!(
        update_dac_both,
        Command::UpdateDac(Channel::Both),
        0x0F_0000
    );
    word!(
        write_input_update_all_b,
        Command::WriteInputUpdateAll(Channel::B, 0xABCD),
        0x11_ABCD
    );
    word!(
        write_input_update_all_a,
        Command::WriteInputUpdateAll(Channel::A, 0x0001),
        0x10_0001
    );
    word!(
        write_and_update_a,
        Command::WriteAndUpdate(Channel::A, 0x4000),
        0x18_4000
    );
    word!(
        write_and_update_both,
        Command::WriteAndUpdate(Channel::Both, 0xC000),
        0x1F_C000
    );
    word!(
        power_normal_both,
        Command::PowerMode(Channel::Both, PowerMode::Normal),
        0x20_0003
    );
    word!(
        power_1k_a,
        Command::PowerMode(Channel::A, PowerMode::PullDown1k),
        0x20_0011
    );
    word!(
        power_100k_b,
        Command::PowerMode(Channel::B, PowerMode::PullDown100k),
        0x20_0022
    );
    word!(
        power_tristate_both,
        Command::PowerMode(Channel::Both, PowerMode::ThreeState),
        0x20_0033
    );
    word!(
        reset_registers,
        Command::Reset(ResetMode::DacAndInputRegisters),
        0x28_0000
    );
    word!(reset_all, Command::Reset(ResetMode::All), 0x28_0001);
    word!(ldac_none, Command::LdacSetup(LdacMask::None), 0x30_0000);
    word!(ldac_a, Command::LdacSetup(LdacMask::A), 0x30_0001);
    word!(ldac_b, Command::LdacSetup(LdacMask::B), 0x30_0002);
    // The thesis configuration word 0x00300003.
    word!(
        ldac_both_thesis_word,
        Command::LdacSetup(LdacMask::Both),
        0x30_0003
    );
    word!(reference_on, Command::InternalReference(true), 0x38_0001);
    word!(reference_off, Command::InternalReference(false), 0x38_0000);

    #[test]
    fn top_bits_are_zero_for_every_command() {
        for c in [
            Command::WriteAndUpdate(Channel::Both, 0xFFFF),
            Command::InternalReference(true),
            Command::PowerMode(Channel::Both, PowerMode::ThreeState),
        ] {
            assert_eq!(c.bits() >> 22, 0);
        }
    }
}
