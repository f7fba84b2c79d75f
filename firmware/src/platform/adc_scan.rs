//! The AD7689 scan as the timer-driven sampler runs it: the CFG word (built with the
//! `ad7689` driver's typed [`Config`]) and the frame pipeline that tags each result with its
//! input.
//!
//! The board's sampler does not go through the driver's `SpiDevice` path: CNV is a timer
//! match output and each 16-bit frame is pushed into the SSP FIFO from the timer interrupt,
//! so a sample costs a few register accesses and no wait (hardware-facts 10.B). The driver
//! still defines *what* is sent: [`SCAN_CONFIG`] is evaluated at compile time, and
//! [`ScanPipeline`] follows the driver's pipeline rules (checked against the driver itself
//! in the tests below).

use crate::platform::board::AI_CHANNELS as CHANNELS;
use ad7689::{Config, InputConfig, Reference, Sequencer};

/// The CFG of the board (hardware-facts 6): overwrite, unipolar to GND (INCC 111), scan
/// IN0..IN7, full bandwidth, external 2.5 V reference with the internal buffer (REF 111),
/// sequencer scanning without the temperature sensor (SEQ 11), no readback (16-bit frames).
pub const SCAN_CONFIG: Config = Config::new()
    .input(InputConfig::UnipolarGnd)
    .channel(CHANNELS as u8 - 1)
    .reference(Reference::ExternalBuffer)
    .sequencer(Sequencer::Scan)
    .readback(false);

/// [`SCAN_CONFIG`] as the 16-bit word on DIN (`CFG << 2`).
pub const SCAN_CFG_WORD: u16 = SCAN_CONFIG.word();

const _: () = assert!(SCAN_CONFIG.is_valid());
const _: () = assert!(SCAN_CONFIG.last_channel() as usize + 1 == CHANNELS);

/// Frames that carry the CFG at start-up (the second one restarts the scan at IN0).
pub const CFG_FRAMES: u32 = 2;
/// The first frame that holds a scan result (IN0).
pub const FIRST_RESULT: u32 = 3;

/// The AD7689 frame pipeline (hardware-facts 6): the CFG sent in frame N governs the
/// conversion whose data arrive in frame N + 2; the second CFG write restarts the scan, so
/// frames 0..=2 hold dummies and from frame 3 on frame k holds IN((k - 3) mod 8).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ScanPipeline {
    frames: u32,
}

impl ScanPipeline {
    /// A pipeline before the first frame.
    pub const fn new() -> Self {
        Self { frames: 0 }
    }

    /// The 16-bit word to send in the next frame: the CFG during start-up, then 0 (DIN low
    /// keeps the CFG: bit 13 = 0).
    pub const fn next_tx(&self) -> u16 {
        if self.frames < CFG_FRAMES {
            SCAN_CFG_WORD
        } else {
            0
        }
    }

    /// Accounts one frame (received, or lost: the channel phase must advance either way);
    /// `Some(input)` when it held a scan result.
    pub fn on_rx(&mut self) -> Option<u8> {
        let k = self.frames;
        // Once the scan runs, `frames` cycles through FIRST_RESULT..FIRST_RESULT + 8, so it
        // never overflows.
        self.frames = if k >= FIRST_RESULT {
            FIRST_RESULT + (k + 1 - FIRST_RESULT) % CHANNELS as u32
        } else {
            k + 1
        };
        (k >= FIRST_RESULT).then(|| (k - FIRST_RESULT) as u8)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ad7689::{Ad7689, Channel};
    use embedded_hal_mock::eh1::delay::NoopDelay;
    use embedded_hal_mock::eh1::spi::{Mock, Transaction};
    use std::vec::Vec;

    #[test]
    fn cfg_word_is_the_boards() {
        // INCC 111, INx 111, BW 1, REF 111, SEQ 11, RB 1; on DIN shifted left by two.
        assert_eq!(SCAN_CONFIG.bits(), 0x3FFF);
        assert_eq!(SCAN_CFG_WORD, 0xFFFC);
    }

    #[test]
    fn start_up_sends_the_cfg_twice_then_keeps_it() {
        let mut p = ScanPipeline::new();
        let mut sent = Vec::new();
        for _ in 0..6 {
            sent.push(p.next_tx());
            p.on_rx();
        }
        assert_eq!(sent, [0xFFFC, 0xFFFC, 0, 0, 0, 0]);
    }

    #[test]
    fn results_cycle_through_the_eight_inputs() {
        let mut p = ScanPipeline::new();
        let tags: Vec<Option<u8>> = (0..3 + 8 * 3).map(|_| p.on_rx()).collect();
        assert_eq!(tags[..3], [None, None, None]);
        for (i, tag) in tags[3..].iter().enumerate() {
            assert_eq!(*tag, Some((i % 8) as u8), "frame {}", i + 3);
        }
    }

    #[test]
    fn counter_stays_bounded() {
        let mut p = ScanPipeline::new();
        for _ in 0..100_000 {
            p.on_rx();
        }
        assert!(p.frames < FIRST_RESULT + 8);
        assert_eq!(p.on_rx(), Some(((100_000 - 3) % 8) as u8));
    }

    /// The same frames through the `ad7689` driver (read after conversion, no busy
    /// indicator): the driver sends what the pipeline sends and tags each result with the
    /// input the pipeline names.
    #[test]
    fn agrees_with_the_driver() {
        const FRAMES: usize = 3 + 8 * 2 + 3;
        let mut p = ScanPipeline::new();
        let mut expected = Vec::new();
        let mut tags = Vec::new();
        for k in 0..FRAMES {
            let din = p.next_tx().to_be_bytes();
            let sdo = (k as u16 * 0x0101).to_be_bytes();
            expected.push(Transaction::transaction_start());
            expected.push(Transaction::transfer_in_place(din.to_vec(), sdo.to_vec()));
            expected.push(Transaction::transaction_end());
            tags.push(p.on_rx());
        }
        let mut adc = Ad7689::new(Mock::new(&expected));
        let mut delay = NoopDelay::new();
        adc.start(SCAN_CONFIG, &mut delay).unwrap();
        for (k, tag) in tags.iter().enumerate().skip(3) {
            let s = adc.read_when_ready(&mut delay).unwrap().unwrap();
            assert_eq!(s.channel, Channel::In(tag.unwrap()), "frame {k}");
            assert_eq!(s.code, k as u16 * 0x0101);
        }
        adc.destroy().done();
    }
}
