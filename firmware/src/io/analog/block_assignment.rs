//! The shape both oversampling assignments share (0x1C13's sample blocks, 0x1C12's update
//! blocks): the plain PDOs first, then the leading oversampling PDOs (each optional, in
//! their order), then the numbered PDOs one by one from the first. Each direction adds its
//! own rules on top ([`super::oversampling::InputBlocks::split`],
//! [`super::output_blocks::OutputBlocks::split`]).

use coe_core::SdoAbortCode;

/// The oversampling PDOs one direction offers.
#[derive(Debug, Clone, Copy)]
pub struct BlockPdos<'a> {
    /// The leading PDOs, in the order they must come.
    pub leading: &'a [u16],
    /// The first numbered PDO.
    pub first: u16,
    /// How many numbered PDOs there are.
    pub count: usize,
}

/// An assignment split by [`BlockPdos::split`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Split {
    /// The plain PDOs before the oversampling ones.
    pub plain: usize,
    /// Bit i: `leading[i]` is assigned.
    pub leading: u8,
    /// Numbered PDOs assigned (from the first on).
    pub numbered: u8,
}

impl Split {
    /// Whether `leading[i]` is assigned.
    pub const fn has(&self, i: usize) -> bool {
        self.leading & (1 << i) != 0
    }
}

impl BlockPdos<'_> {
    /// Whether `pdo` is one of these PDOs.
    #[inline(always)]
    pub fn contains(&self, pdo: u16) -> bool {
        self.leading.contains(&pdo) || usize::from(pdo.wrapping_sub(self.first)) < self.count
    }

    /// Splits `pdos` (see the module); a PDO out of its place is 0x06040043.
    // Inlined: each direction's PDOs are constants, which the copy for it folds in.
    #[inline(always)]
    pub fn split(&self, pdos: &[u16]) -> Result<Split, SdoAbortCode> {
        let plain = pdos
            .iter()
            .position(|p| self.contains(*p))
            .unwrap_or(pdos.len());
        let mut split = Split {
            plain,
            leading: 0,
            numbered: 0,
        };
        let mut rest = pdos.get(plain..).unwrap_or(&[]);
        for (i, lead) in self.leading.iter().enumerate() {
            if let [pdo, tail @ ..] = rest {
                if pdo == lead {
                    split.leading |= 1 << i;
                    rest = tail;
                }
            }
        }
        for (n, pdo) in rest.iter().enumerate() {
            if n >= self.count || usize::from(pdo.wrapping_sub(self.first)) != n {
                return Err(SdoAbortCode::ParameterIncompatible);
            }
            split.numbered += 1;
        }
        Ok(split)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const PDOS: BlockPdos<'static> = BlockPdos {
        leading: &[0x1A10, 0x1A11],
        first: 0x1A20,
        count: 3,
    };

    fn split(pdos: &[u16]) -> Result<(usize, u8, u8), SdoAbortCode> {
        PDOS.split(pdos).map(|s| (s.plain, s.leading, s.numbered))
    }

    #[test]
    fn plain_then_leading_in_order_then_numbered_one_by_one() {
        assert_eq!(split(&[]), Ok((0, 0, 0)));
        assert_eq!(split(&[0x1A00, 0x1A01]), Ok((2, 0, 0)));
        assert_eq!(split(&[0x1A00, 0x1A10, 0x1A11, 0x1A20]), Ok((1, 0b11, 1)));
        assert_eq!(split(&[0x1A11, 0x1A20, 0x1A21, 0x1A22]), Ok((0, 0b10, 3)));
        assert!(PDOS.split(&[0x1A10]).unwrap().has(0));
        assert!(!PDOS.split(&[0x1A10]).unwrap().has(1));
    }

    #[test]
    fn anything_out_of_place_is_incompatible() {
        let bad = Err(SdoAbortCode::ParameterIncompatible);
        // Leading PDOs out of order, numbered ones with a gap, twice, past the last, and a
        // plain PDO after the oversampling ones.
        assert_eq!(split(&[0x1A11, 0x1A10]), bad);
        assert_eq!(split(&[0x1A20, 0x1A22]), bad);
        assert_eq!(split(&[0x1A20, 0x1A20]), bad);
        assert_eq!(split(&[0x1A20, 0x1A21, 0x1A22, 0x1A23]), bad);
        assert_eq!(split(&[0x1A20, 0x1A00]), bad);
        assert_eq!(split(&[0x1A20, 0x1A10]), bad);
    }
}
