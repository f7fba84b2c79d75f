//! SyncManagers: mailbox (1-buffer) and 3-buffer mode (ESC datasheet Section I ch. 8).

use super::{regs, regs::al_event, AccessResult, Esc, Op, Side};

/// Per-SyncManager buffer state (the register block itself lives in ESC memory).
#[derive(Clone, Debug, Default)]
pub(super) struct SmState {
    /// Mailbox: buffer full.
    full: bool,
    /// Write access to the buffer is open (first byte accessed, last byte not yet).
    write_open: bool,
    /// Read access to the buffer is open.
    read_open: bool,
    /// 3-buffer: the buffer being written.
    write_buf: Option<u8>,
    /// 3-buffer: the buffer being read.
    read_buf: Option<u8>,
    /// 3-buffer: the latest completely written buffer.
    latest: Option<u8>,
    /// 3-buffer: the buffer the reader saw last (used before anything was written).
    last_read: u8,
    /// Status interrupt-write flag (b0).
    int_w: bool,
    /// Status interrupt-read flag (b1).
    int_r: bool,
}

/// Decoded SyncManager register block.
#[derive(Clone, Copy, Debug)]
pub(super) struct SmRegs {
    pub start: u16,
    pub len: u16,
    pub control: u8,
    pub activate: u8,
    pub pdi_control: u8,
}

impl SmRegs {
    fn mailbox(&self) -> bool {
        self.control & 0x03 == 0x02
    }
    /// The side that writes into this SM's buffer.
    fn writer(&self) -> Side {
        if self.control & 0x0C == 0x04 {
            Side::Ecat
        } else {
            Side::Pdi
        }
    }
    fn enabled(&self) -> bool {
        self.activate & 0x01 != 0 && self.pdi_control & 0x01 == 0 && self.len > 0
    }
}

impl Esc {
    pub(super) fn sm_regs(&self, n: usize) -> SmRegs {
        let b = regs::sm(n);
        SmRegs {
            start: self.peek_u16(b),
            len: self.peek_u16(b + 2),
            control: self.peek_u8(b + 4),
            activate: self.peek_u8(b + 6),
            pdi_control: self.peek_u8(b + 7),
        }
    }

    /// The enabled SM whose (first) buffer contains `addr`: (index, start, len).
    pub(super) fn sm_at(&self, _side: Side, addr: u32) -> Option<(usize, u32, u32)> {
        (0..8).find_map(|n| {
            let r = self.sm_regs(n);
            let (s, l) = (r.start as u32, r.len as u32);
            (r.enabled() && addr >= s && addr < s + l).then_some((n, s, l))
        })
    }

    /// The lowest enabled SM buffer start above `addr`.
    pub(super) fn next_sm_start(&self, _side: Side, addr: u32) -> Option<u32> {
        (0..8)
            .filter_map(|n| {
                let r = self.sm_regs(n);
                (r.enabled() && r.start as u32 > addr).then_some(r.start as u32)
            })
            .min()
    }

    /// SM status register (0x0805 + 8n), computed from the buffer state.
    pub(super) fn sm_status(&self, n: usize) -> u8 {
        let r = self.sm_regs(n);
        let s = &self.sms[n];
        let mut v = 0u8;
        if s.int_w {
            v |= 0x01;
        }
        if s.int_r {
            v |= 0x02;
        }
        if r.mailbox() {
            if s.full {
                v |= 0x08;
            }
        } else {
            v |= (s.latest.unwrap_or(3) & 0x03) << 4;
        }
        if s.read_open {
            v |= 0x40;
        }
        if s.write_open {
            v |= 0x80;
        }
        v
    }

    /// Whether SM `n`'s mailbox is full (mailbox mode).
    pub fn sm_mailbox_full(&self, n: usize) -> bool {
        self.sms[n].full
    }

    /// One access to the part `[off, off + buf.len())` of SM `n`'s buffer.
    pub(super) fn sm_access(
        &mut self,
        side: Side,
        n: usize,
        off: u32,
        buf: &mut [u8],
        incoming: &[u8],
        op: Op,
    ) -> AccessResult {
        let r = self.sm_regs(n);
        let first = off == 0;
        let last = off + buf.len() as u32 == r.len as u32;
        let mut res = AccessResult::default();
        if side == r.writer() {
            if op.writes() {
                res.written = if r.mailbox() {
                    self.mbx_write(n, &r, off, incoming, first, last)
                } else {
                    self.buf3_write(n, &r, off, incoming, first, last)
                };
            }
        } else if op.reads() {
            let ok = if r.mailbox() {
                self.mbx_read(n, &r, off, buf, op.ors(), first, last)
            } else {
                self.buf3_read(n, &r, off, buf, op.ors(), first, last)
            };
            res.read = ok;
        }
        res
    }

    fn copy_out(&self, phys: u32, buf: &mut [u8], or: bool) {
        for (i, b) in buf.iter_mut().enumerate() {
            let v = self.mem.get(phys as usize + i).copied().unwrap_or(0);
            if or {
                *b |= v;
            } else {
                *b = v;
            }
        }
    }

    fn copy_in(&mut self, phys: u32, data: &[u8]) {
        for (i, b) in data.iter().enumerate() {
            if let Some(m) = self.mem.get_mut(phys as usize + i) {
                *m = *b;
            }
        }
    }

    /// The writer opened the buffer: events of the counterpart are acknowledged.
    fn sm_opened_by(&mut self, n: usize, side: Side) {
        match side {
            Side::Pdi => self.clear_al_event(al_event::sm(n)),
            Side::Ecat => self.clear_ecat_event(1 << (4 + n)),
        }
    }

    /// A buffer access by `side` completed (write or read): notify the other side.
    fn sm_completed_by(&mut self, n: usize, r: &SmRegs, side: Side) {
        match side {
            Side::Ecat => {
                if r.control & 0x20 != 0 {
                    self.set_al_event(al_event::sm(n));
                }
            }
            Side::Pdi => {
                if r.control & 0x10 != 0 {
                    self.set_ecat_event(1 << (4 + n));
                }
            }
        }
    }

    fn mbx_write(
        &mut self,
        n: usize,
        r: &SmRegs,
        off: u32,
        data: &[u8],
        first: bool,
        last: bool,
    ) -> bool {
        if self.sms[n].full {
            return false;
        }
        if first {
            self.sms[n].write_open = true;
            self.sms[n].int_r = false;
            self.sm_opened_by(n, r.writer());
        }
        if !self.sms[n].write_open {
            return false;
        }
        self.copy_in(r.start as u32 + off, data);
        if last {
            let s = &mut self.sms[n];
            s.write_open = false;
            s.full = true;
            s.int_w = true;
            self.sm_completed_by(n, r, r.writer());
            if r.writer() == Side::Ecat && r.control & 0x40 != 0 {
                self.wd_trigger();
            }
        }
        true
    }

    #[allow(clippy::too_many_arguments)]
    fn mbx_read(
        &mut self,
        n: usize,
        r: &SmRegs,
        off: u32,
        buf: &mut [u8],
        or: bool,
        first: bool,
        last: bool,
    ) -> bool {
        if !self.sms[n].full {
            return false;
        }
        let reader = if r.writer() == Side::Ecat {
            Side::Pdi
        } else {
            Side::Ecat
        };
        if first {
            self.sms[n].read_open = true;
            self.sms[n].int_w = false;
            self.sm_opened_by(n, reader);
        }
        if !self.sms[n].read_open {
            return false;
        }
        self.copy_out(r.start as u32 + off, buf, or);
        if last {
            let s = &mut self.sms[n];
            s.read_open = false;
            s.full = false;
            s.int_r = true;
            self.sm_completed_by(n, r, reader);
        }
        true
    }

    fn buf3_write(
        &mut self,
        n: usize,
        r: &SmRegs,
        off: u32,
        data: &[u8],
        first: bool,
        last: bool,
    ) -> bool {
        if first {
            let s = &self.sms[n];
            let busy = [s.latest, s.read_buf];
            let free = (0u8..3).find(|b| !busy.contains(&Some(*b))).unwrap_or(0);
            self.sms[n].write_buf = Some(free);
            self.sms[n].write_open = true;
            self.sms[n].int_r = false;
            self.sm_opened_by(n, r.writer());
        }
        let Some(b) = self.sms[n].write_buf else {
            return false;
        };
        let phys = r.start as u32 + b as u32 * r.len as u32 + off;
        self.copy_in(phys, data);
        if last {
            let s = &mut self.sms[n];
            s.latest = Some(b);
            s.write_buf = None;
            s.write_open = false;
            s.int_w = true;
            if r.writer() == Side::Pdi && self.record_pdi_buffer_writes {
                self.pdi_buffer_writes.push((n as u8, self.now_ns));
            }
            self.sm_completed_by(n, r, r.writer());
            if r.writer() == Side::Ecat && r.control & 0x40 != 0 {
                self.wd_trigger();
            }
        }
        true
    }

    #[allow(clippy::too_many_arguments)]
    fn buf3_read(
        &mut self,
        n: usize,
        r: &SmRegs,
        off: u32,
        buf: &mut [u8],
        or: bool,
        first: bool,
        last: bool,
    ) -> bool {
        let reader = if r.writer() == Side::Ecat {
            Side::Pdi
        } else {
            Side::Ecat
        };
        if first {
            let s = &mut self.sms[n];
            let b = s.latest.unwrap_or(s.last_read);
            s.read_buf = Some(b);
            s.read_open = true;
            s.int_w = false;
            self.sm_opened_by(n, reader);
        }
        let Some(b) = self.sms[n].read_buf else {
            return false;
        };
        let phys = r.start as u32 + b as u32 * r.len as u32 + off;
        self.copy_out(phys, buf, or);
        if last {
            let s = &mut self.sms[n];
            s.last_read = b;
            s.read_buf = None;
            s.read_open = false;
            s.int_r = true;
            self.sm_completed_by(n, r, reader);
        }
        true
    }

    /// The master wrote the activation register 0x0806+8n (old value given).
    pub(super) fn sm_activation_written(&mut self, n: usize, old: u8) {
        let new = self.peek_u8(regs::sm(n) + 6);
        if (old ^ new) & 0x01 != 0 {
            // Enabling or disabling resets the buffer state.
            self.sms[n] = SmState::default();
        }
        if old != new {
            self.set_al_event(al_event::SM_ACTIVATION);
        }
    }

    /// The PDI wrote 0x0807+8n (deactivate / repeat ack).
    pub(super) fn sm_pdi_control_written(&mut self, n: usize) {
        if self.peek_u8(regs::sm(n) + 7) & 0x01 != 0 {
            self.sms[n] = SmState::default();
        }
    }
}
