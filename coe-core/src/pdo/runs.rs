//! The process image as runs: consecutive elements of one object (subindices n, n + 1, ...
//! of one length, back to back) are one [`ImageRun`], so the layout of a PDO of 32 samples
//! of one array takes one entry instead of 32. For images of sample arrays (oversampling,
//! ~0.5 KB per direction), where [`super::ImageLayout`] would need a field per sample.
//!
//! The entries come from the caller per PDO ([`ImageRuns::build`]): from the mapping objects
//! in RAM for configurable PDOs, or from the dictionary's defaults
//! ([`crate::device::DeviceDescription::pdo_entries`]) for fixed ones, which then need no
//! RAM at all.

use super::PdoEntry;
use crate::abort::SdoAbortCode;
use crate::esm::AlState;
use crate::od::ObjectAccess;

/// Consecutive elements of one object in the image: `count` subindices from
/// `first_subindex` of `index`, `bit_len` bits each, from `bit_offset` on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ImageRun {
    /// Object index.
    pub index: u16,
    /// Subindex of the first element.
    pub first_subindex: u8,
    /// Elements (1..=255).
    pub count: u8,
    /// Length of each element in bits (1..=64).
    pub bit_len: u8,
    /// Bit offset of the first element from the start of the image.
    pub bit_offset: u32,
}

impl ImageRun {
    /// Bit offset of element `i` (0-based).
    pub const fn element_offset(&self, i: u8) -> u32 {
        self.bit_offset + i as u32 * self.bit_len as u32
    }

    /// Bits of the whole run.
    pub const fn bit_len_total(&self) -> u32 {
        self.count as u32 * self.bit_len as u32
    }

    /// Whether `entry` continues this run: same object and length, the next subindex,
    /// placed right after it.
    const fn continued_by(&self, entry: &PdoEntry, at: u32) -> bool {
        self.index == entry.index
            && self.bit_len == entry.bit_len
            && self.count < u8::MAX
            && self.first_subindex as u16 + self.count as u16 == entry.subindex as u16
            && self.bit_offset + self.bit_len_total() == at
    }
}

/// One direction's process image as runs (room for `N` runs), gaps skipped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ImageRuns<const N: usize = 16> {
    runs: [ImageRun; N],
    count: usize,
    bit_len: u32,
}

impl<const N: usize> Default for ImageRuns<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> ImageRuns<N> {
    /// An empty image.
    pub const fn new() -> Self {
        const NONE: ImageRun = ImageRun {
            index: 0,
            first_subindex: 0,
            count: 0,
            bit_len: 0,
            bit_offset: 0,
        };
        Self {
            runs: [NONE; N],
            count: 0,
            bit_len: 0,
        }
    }

    /// Lays out `pdos` in order, with the entries `entries_of` gives for each PDO index
    /// (`None`: no such PDO). Errors: an unknown PDO (0x06090030, as
    /// [`super::ImageLayout::build`]), more than `N` runs (0x06040042), an entry longer than
    /// 64 bits or of length 0 (0x06040041).
    pub fn build<I>(
        pdos: &[u16],
        mut entries_of: impl FnMut(u16) -> Option<I>,
    ) -> Result<Self, SdoAbortCode>
    where
        I: IntoIterator<Item = PdoEntry>,
    {
        let mut image = Self::new();
        for pdo in pdos {
            let entries = entries_of(*pdo).ok_or(SdoAbortCode::ValueRangeExceeded)?;
            for entry in entries {
                image.append(entry)?;
            }
        }
        Ok(image)
    }

    fn append(&mut self, entry: PdoEntry) -> Result<(), SdoAbortCode> {
        if entry.bit_len == 0 || entry.bit_len > 64 {
            return Err(SdoAbortCode::CannotBeMapped);
        }
        let at = self.bit_len;
        self.bit_len += u32::from(entry.bit_len);
        if entry.is_gap() {
            return Ok(());
        }
        if let Some(last) = self.runs.get_mut(..self.count).and_then(|r| r.last_mut()) {
            if last.continued_by(&entry, at) {
                last.count += 1;
                return Ok(());
            }
        }
        let run = self
            .runs
            .get_mut(self.count)
            .ok_or(SdoAbortCode::PdoLengthExceeded)?;
        *run = ImageRun {
            index: entry.index,
            first_subindex: entry.subindex,
            count: 1,
            bit_len: entry.bit_len,
            bit_offset: at,
        };
        self.count += 1;
        Ok(())
    }

    /// The runs in image order.
    pub fn runs(&self) -> &[ImageRun] {
        self.runs.get(..self.count).unwrap_or(&self.runs)
    }

    /// Image length in bits.
    pub const fn bit_len(&self) -> u32 {
        self.bit_len
    }

    /// Image length in bytes (`ceil(bits / 8)`, the SyncManager length).
    pub const fn byte_len(&self) -> usize {
        (self.bit_len as usize).div_ceil(8)
    }

    /// The bit offset of `index:subindex` in the image (`None` if it is not mapped).
    pub fn locate(&self, index: u16, subindex: u8) -> Option<u32> {
        self.runs().iter().find_map(|r| {
            let i = subindex.checked_sub(r.first_subindex)?;
            (r.index == index && i < r.count).then(|| r.element_offset(i))
        })
    }

    /// Every mapped element with its bit offset and length, in image order.
    pub fn elements(&self) -> impl Iterator<Item = (u16, u8, u32, u8)> + '_ {
        self.runs().iter().flat_map(|r| {
            (0..r.count).map(move |i| {
                (
                    r.index,
                    r.first_subindex.wrapping_add(i),
                    r.element_offset(i),
                    r.bit_len,
                )
            })
        })
    }

    /// Packs the inputs element by element through `app` (see
    /// [`super::ImageLayout::pack`]; a firmware moves its sample runs itself). Errors:
    /// `image` shorter than the layout (0x06040042) or whatever `app.read` returns.
    pub fn pack<A: ObjectAccess + ?Sized>(
        &self,
        app: &mut A,
        image: &mut [u8],
    ) -> Result<(), SdoAbortCode> {
        if image.len() < self.byte_len() {
            return Err(SdoAbortCode::PdoLengthExceeded);
        }
        for (index, subindex, offset, bits) in self.elements() {
            let mut value = [0u8; 8];
            app.read(index, subindex, &mut value)?;
            super::write_bits(image, offset, bits, &value);
        }
        Ok(())
    }

    /// Unpacks the outputs element by element to `app` (see [`super::ImageLayout::unpack`]).
    pub fn unpack<A: ObjectAccess + ?Sized>(
        &self,
        image: &[u8],
        app: &mut A,
        state: AlState,
    ) -> Result<(), SdoAbortCode> {
        if image.len() < self.byte_len() {
            return Err(SdoAbortCode::PdoLengthExceeded);
        }
        for (index, subindex, offset, bits) in self.elements() {
            let mut value = [0u8; 8];
            super::read_bits(image, offset, bits, &mut value);
            let len = usize::from(bits).div_ceil(8);
            app.write(index, subindex, value.get(..len).unwrap_or(&value), state)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec;
    use std::vec::Vec;

    /// The oversampling input image of the design (docs/book/oversampling.md): a status
    /// PDO (32-bit counter, two 8-bit fields), a 64-bit time, two PDOs of 32 samples.
    fn entries(pdo: u16) -> Option<Vec<PdoEntry>> {
        match pdo {
            0x1A10 => Some(vec![
                PdoEntry::new(0x6010, 1, 32),
                PdoEntry::new(0x6010, 2, 8),
                PdoEntry::new(0x6010, 3, 8),
            ]),
            0x1A11 => Some(vec![PdoEntry::new(0x6010, 4, 64)]),
            0x1A20 | 0x1A21 => Some(
                (1..=32)
                    .map(|s| PdoEntry::new(0x6020 + (pdo - 0x1A20), s, 16))
                    .collect(),
            ),
            0x1A30 => Some(vec![
                PdoEntry::new(0x7000, 1, 16),
                PdoEntry::gap(8),
                PdoEntry::new(0x7000, 2, 16),
                PdoEntry::new(0x7000, 3, 16),
                PdoEntry::new(0x7000, 5, 16),
                PdoEntry::new(0x7000, 6, 8),
            ]),
            _ => None,
        }
    }

    fn run(index: u16, first: u8, count: u8, bits: u8, offset: u32) -> ImageRun {
        ImageRun {
            index,
            first_subindex: first,
            count,
            bit_len: bits,
            bit_offset: offset,
        }
    }

    #[test]
    fn sample_arrays_are_one_run_per_pdo() {
        // 0x6010:02 and :03 (8 bits each) are one run too.
        let image: ImageRuns<8> =
            ImageRuns::build(&[0x1A10, 0x1A11, 0x1A20, 0x1A21], entries).unwrap();
        assert_eq!(
            image.runs(),
            [
                run(0x6010, 1, 1, 32, 0),
                run(0x6010, 2, 2, 8, 32),
                run(0x6010, 4, 1, 64, 48),
                run(0x6020, 1, 32, 16, 112),
                run(0x6021, 1, 32, 16, 624),
            ]
        );
        assert_eq!((image.bit_len(), image.byte_len()), (1136, 142));
        assert_eq!(image.locate(0x6020, 1), Some(112));
        assert_eq!(image.locate(0x6021, 32), Some(624 + 31 * 16));
        assert_eq!(image.locate(0x6021, 33), None);
        assert_eq!(image.locate(0x6022, 1), None);
        assert_eq!(image.elements().count(), 4 + 64);
    }

    #[test]
    fn gaps_other_lengths_and_holes_start_new_runs() {
        let image: ImageRuns<8> = ImageRuns::build(&[0x1A30], entries).unwrap();
        assert_eq!(
            image.runs(),
            [
                run(0x7000, 1, 1, 16, 0),
                run(0x7000, 2, 2, 16, 24),
                run(0x7000, 5, 1, 16, 56),
                run(0x7000, 6, 1, 8, 72),
            ]
        );
        assert_eq!(image.bit_len(), 80);
    }

    #[test]
    fn errors_name_the_cause() {
        let none: Result<ImageRuns<8>, _> = ImageRuns::build(&[0x1A99], entries);
        assert_eq!(none, Err(SdoAbortCode::ValueRangeExceeded));
        let small: Result<ImageRuns<4>, _> =
            ImageRuns::build(&[0x1A10, 0x1A11, 0x1A20, 0x1A21], entries);
        assert_eq!(small, Err(SdoAbortCode::PdoLengthExceeded));
        let wide: Result<ImageRuns<2>, _> =
            ImageRuns::build(&[1], |_| Some([PdoEntry::new(0x6000, 1, 65)]));
        assert_eq!(wide, Err(SdoAbortCode::CannotBeMapped));
        // 255 elements in one run, the 256th starts a new one.
        let long: ImageRuns<2> = ImageRuns::build(&[1], |_| {
            Some((0..=255u16).map(|i| PdoEntry::new(0x6000, i as u8, 8)))
        })
        .unwrap();
        assert_eq!(long.runs()[0].count, 255);
        assert_eq!(long.runs()[1], run(0x6000, 255, 1, 8, 255 * 8));
    }

    /// Sample `s` of block `b` (0x6020 + b) reads `0x100 * b + s`; the status fields read
    /// fixed values.
    struct Samples {
        written: Vec<(u16, u8, Vec<u8>)>,
    }

    impl ObjectAccess for Samples {
        fn read(&mut self, index: u16, sub: u8, buf: &mut [u8]) -> Result<usize, SdoAbortCode> {
            let v: u64 = match (index, sub) {
                (0x6010, 1) => 0x0403_0201,
                (0x6010, 2) => 0x05,
                (0x6010, 3) => 0x06,
                (0x6010, 4) => 0x0F0E_0D0C_0B0A_0908,
                (0x6020..=0x6021, s) => 0x100 * u64::from(index - 0x6020) + u64::from(s),
                _ => return Err(SdoAbortCode::ObjectDoesNotExist),
            };
            buf[..8].copy_from_slice(&v.to_le_bytes());
            Ok(8)
        }
        fn write(&mut self, i: u16, s: u8, d: &[u8], _: AlState) -> Result<(), SdoAbortCode> {
            self.written.push((i, s, d.to_vec()));
            Ok(())
        }
    }

    /// Golden bytes: counter, two status bytes, the time, then the samples little-endian.
    static GOLDEN_HEAD: [u8; 14] = [1, 2, 3, 4, 5, 6, 8, 9, 10, 11, 12, 13, 14, 15];

    #[test]
    fn pack_and_unpack_golden_bytes() {
        let image: ImageRuns<8> =
            ImageRuns::build(&[0x1A10, 0x1A11, 0x1A20, 0x1A21], entries).unwrap();
        let mut app = Samples {
            written: Vec::new(),
        };
        let mut bytes = [0xA5u8; 142];
        image.pack(&mut app, &mut bytes).unwrap();
        assert_eq!(bytes[..14], GOLDEN_HEAD);
        assert_eq!(bytes[14..18], [1, 0, 2, 0], "0x6020:01, :02");
        assert_eq!(
            bytes[76..82],
            [32, 0, 1, 1, 2, 1],
            "0x6020:20, 0x6021:01, :02"
        );
        assert_eq!(bytes[140..142], [32, 1], "0x6021:20");
        assert_eq!(
            image.pack(&mut app, &mut [0; 141]),
            Err(SdoAbortCode::PdoLengthExceeded)
        );
        image.unpack(&bytes, &mut app, AlState::Op).unwrap();
        assert_eq!(app.written.len(), 68);
        assert_eq!(app.written[0], (0x6010, 1, vec![1, 2, 3, 4]));
        assert_eq!(app.written[2], (0x6010, 3, vec![6]));
        assert_eq!(app.written[67], (0x6021, 32, vec![32, 1]));
    }
}
