//! What one frame sends on DIN.

use crate::config::Config;

/// The DIN content of one frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Command {
    /// DIN low for the whole frame: bit 13 (overwrite) is 0, the CFG stays as it is (the
    /// datasheet asks DIN to be low at least for bit 13 when no CFG is written).
    Keep,
    /// The 14-bit CFG in the first 14 SCK (`cfg << 2`), then zeros.
    Write(Config),
}

impl Command {
    /// The command for an optional CFG.
    pub(crate) const fn new(cfg: Option<Config>) -> Self {
        match cfg {
            Some(c) => Command::Write(c),
            None => Command::Keep,
        }
    }

    /// The first 16 bits on DIN, MSB first.
    pub(crate) const fn word(self) -> u16 {
        match self {
            Command::Keep => 0x0000,
            Command::Write(cfg) => cfg.word(),
        }
    }

    /// The DIN bytes of a frame (the bytes after the first two are zero).
    pub(crate) const fn bytes(self) -> [u8; 4] {
        let w = self.word();
        [(w >> 8) as u8, w as u8, 0, 0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{Reference, Sequencer};

    #[test]
    fn keep_is_all_zero() {
        assert_eq!(Command::Keep.word(), 0);
        assert_eq!(Command::new(None).bytes(), [0, 0, 0, 0]);
    }

    #[test]
    fn write_is_cfg_shifted_left_by_two() {
        let cfg = Config::new()
            .channel(7)
            .reference(Reference::Internal4V096)
            .sequencer(Sequencer::Scan);
        assert_eq!(Command::Write(cfg).word(), 0xFF3C);
        assert_eq!(Command::new(Some(cfg)).bytes(), [0xFF, 0x3C, 0, 0]);
        let ext = cfg.reference(Reference::External);
        assert_eq!(Command::Write(ext).bytes(), [0xFF, 0xDC, 0, 0]);
    }
}
