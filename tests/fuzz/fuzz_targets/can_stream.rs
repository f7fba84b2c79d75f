//! The input of the CAN fuzz targets: a stream of frames, each `flags, dt, id low, id high,
//! dlc, data[dlc]` (flags bit 0: remote frame; dt: milliseconds since the frame before;
//! the identifier and the DLC are masked to 11 bits and 0..=8). `cargo xtask fuzz` writes
//! seeds in this form from the CAN tests' traffic.

use coe_core::canopen::CanFrame;

/// The frames of `data` with their time (µs), until the input runs out.
pub fn frames(data: &[u8]) -> impl Iterator<Item = (u64, CanFrame)> + '_ {
    let mut rest = data;
    let mut now_us = 0u64;
    core::iter::from_fn(move || {
        let (&[flags, dt, lo, hi, dlc], tail) = rest.split_first_chunk::<5>()?;
        let id = u16::from_le_bytes([lo, hi]) & 0x7FF;
        let dlc = dlc % 9;
        now_us += u64::from(dt) * 1000;
        let frame = if flags & 1 != 0 {
            rest = tail;
            CanFrame::remote(id, dlc).ok()?
        } else {
            let n = usize::from(dlc).min(tail.len());
            let (payload, after) = tail.split_at(n);
            rest = after;
            CanFrame::new(id, payload).ok()?
        };
        Some((now_us, frame))
    })
}
