//! FMMUs: bit-granular mapping of logical addresses onto ESC memory
//! (ESC datasheet Section I ch. 7, Section II 0x0600).

use super::{regs, AccessResult, Esc, Op, Side};

/// Decoded FMMU register block.
#[derive(Clone, Copy, Debug)]
struct FmmuRegs {
    log_start: u32,
    len: u16,
    log_start_bit: u8,
    log_stop_bit: u8,
    phys_start: u16,
    phys_start_bit: u8,
    read: bool,
    write: bool,
    active: bool,
}

impl Esc {
    fn fmmu_regs(&self, n: usize) -> FmmuRegs {
        let b = regs::fmmu(n);
        let ty = self.peek_u8(b + 0x0B);
        FmmuRegs {
            log_start: self.peek_u32(b),
            len: self.peek_u16(b + 4),
            log_start_bit: self.peek_u8(b + 6) & 7,
            log_stop_bit: self.peek_u8(b + 7) & 7,
            phys_start: self.peek_u16(b + 8),
            phys_start_bit: self.peek_u8(b + 0x0A) & 7,
            read: ty & 0x01 != 0,
            write: ty & 0x02 != 0,
            active: self.peek_u8(b + 0x0C) & 0x01 != 0,
        }
    }

    /// A logical access (LRD/LWR/LRW) of the datagram data `data` at logical address `la`.
    ///
    /// For each active FMMU whose logical bit range overlaps the datagram, the
    /// overlapping bits are read from / written to physical memory through
    /// [`Esc::access`] (so SyncManager rules apply). Writes use the incoming data;
    /// reads replace the mapped bits of the outgoing data.
    pub(super) fn logical_access(&mut self, la: u32, data: &mut [u8], op: Op) -> AccessResult {
        let incoming = data.to_vec();
        let dg_first_bit = la as u64 * 8;
        let dg_end_bit = dg_first_bit + data.len() as u64 * 8; // exclusive
        let mut res = AccessResult::default();
        for n in 0..8 {
            let f = self.fmmu_regs(n);
            if !f.active || f.len == 0 {
                continue;
            }
            let f_first = f.log_start as u64 * 8 + f.log_start_bit as u64;
            let f_last = (f.log_start as u64 + f.len as u64 - 1) * 8 + f.log_stop_bit as u64;
            let lo = dg_first_bit.max(f_first);
            let hi = dg_end_bit.min(f_last + 1); // exclusive
            if lo >= hi {
                continue;
            }
            let p_first_bit = f.phys_start as u64 * 8 + f.phys_start_bit as u64 + (lo - f_first);
            let p_end_bit = p_first_bit + (hi - lo);
            let p_byte = (p_first_bit / 8) as u32;
            let p_len = p_end_bit.div_ceil(8) as usize - p_byte as usize;
            let map = |lbit: u64| -> (usize, usize) {
                let pbit = p_first_bit + (lbit - lo) - p_byte as u64 * 8;
                ((pbit / 8) as usize, (pbit % 8) as usize)
            };
            let dg = |lbit: u64| -> (usize, usize) {
                let d = lbit - dg_first_bit;
                ((d / 8) as usize, (d % 8) as usize)
            };
            let wants_read = op.reads() && f.read;
            let wants_write = op.writes() && f.write;
            if wants_read {
                let mut phys = vec![0u8; p_len];
                let r = self.access(Side::Ecat, p_byte, &mut phys, Op::Read);
                if r.read {
                    res.read = true;
                    for lbit in lo..hi {
                        let (pb, pi) = map(lbit);
                        let (db, di) = dg(lbit);
                        let bit = (phys[pb] >> pi) & 1;
                        if op.ors() {
                            data[db] |= bit << di;
                        } else {
                            data[db] = (data[db] & !(1 << di)) | (bit << di);
                        }
                    }
                }
            }
            if wants_write {
                // Read-modify-write of partial bytes (unmapped bits keep their value).
                let mut phys = vec![0u8; p_len];
                self.peek(p_byte as u16, &mut phys);
                for lbit in lo..hi {
                    let (pb, pi) = map(lbit);
                    let (db, di) = dg(lbit);
                    let bit = (incoming[db] >> di) & 1;
                    phys[pb] = (phys[pb] & !(1 << pi)) | (bit << pi);
                }
                let r = self.access(Side::Ecat, p_byte, &mut phys, Op::Write);
                res.written |= r.written;
            }
        }
        res
    }
}
