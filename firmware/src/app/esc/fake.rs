//! A register-file ESC for the host tests: the PDI side through [`EscPort`], the master
//! side through the `master_*` methods, with the SyncManager behaviour the application
//! relies on (mailbox full/empty on the last byte, 3-buffer outputs, read-to-clear events).
//!
//! Also used outside the crate's tests (feature `fake-esc`): the Cortex-M3 benchmark
//! (`xtask/bench-cm3`) runs the application's hot paths against it in RAM.

use super::{event, reg, EscPort, SmConfig};

/// The register file (0x0000..0x2000) with the PDI-side effects of the ET1100.
pub struct FakeEsc {
    /// ESC memory.
    pub mem: [u8; 0x2000],
    /// Fail the next PDI access with [`BusError`].
    pub fail_next: bool,
    /// PDI writes so far.
    pub writes: usize,
    /// PDI reads so far (any address).
    pub reads: usize,
    /// PDI reads touching the SyncManager registers (0x0800..0x0880).
    pub sm_register_reads: usize,
}

/// A PDI access outside the register file or to a register the PDI cannot write.
#[derive(Debug, PartialEq, Eq)]
pub struct BusError;

impl Default for FakeEsc {
    fn default() -> Self {
        Self::new()
    }
}

impl FakeEsc {
    /// INIT, PD watchdog OK, no SyncManager configured.
    pub fn new() -> Self {
        let mut esc = Self {
            mem: [0; 0x2000],
            fail_next: false,
            writes: 0,
            reads: 0,
            sm_register_reads: 0,
        };
        esc.set_u16(reg::AL_STATUS, 1);
        esc.set_u16(reg::WD_STATUS_PD, 1);
        for n in 0..4u8 {
            esc.mem[usize::from(reg::SM_BASE) + 8 * usize::from(n) + 5] = 0x30;
        }
        esc
    }

    pub fn u16_at(&self, addr: u16) -> u16 {
        let a = usize::from(addr);
        u16::from_le_bytes([self.mem[a], self.mem[a + 1]])
    }

    pub fn set_u16(&mut self, addr: u16, v: u16) {
        let a = usize::from(addr);
        self.mem[a..a + 2].copy_from_slice(&v.to_le_bytes());
    }

    fn events_word(&self) -> u32 {
        let a = usize::from(reg::AL_EVENT);
        u32::from_le_bytes([
            self.mem[a],
            self.mem[a + 1],
            self.mem[a + 2],
            self.mem[a + 3],
        ])
    }

    pub fn raise(&mut self, bits: u32) {
        let v = self.events_word() | bits;
        let a = usize::from(reg::AL_EVENT);
        self.mem[a..a + 4].copy_from_slice(&v.to_le_bytes());
    }

    fn clear(&mut self, bits: u32) {
        let v = self.events_word() & !bits;
        let a = usize::from(reg::AL_EVENT);
        self.mem[a..a + 4].copy_from_slice(&v.to_le_bytes());
    }

    pub fn sm(&self, n: u8) -> SmConfig {
        let a = usize::from(reg::SM_BASE) + 8 * usize::from(n);
        let mut b = [0u8; 8];
        b.copy_from_slice(&self.mem[a..a + 8]);
        SmConfig::from_bytes(b)
    }

    pub fn set_sm(&mut self, n: u8, cfg: SmConfig) {
        let a = usize::from(reg::SM_BASE) + 8 * usize::from(n);
        self.mem[a..a + 8].copy_from_slice(&cfg.to_bytes());
    }

    fn set_sm_status_bit(&mut self, n: u8, bit: u8, on: bool) {
        let a = usize::from(reg::SM_BASE) + 8 * usize::from(n) + 5;
        if on {
            self.mem[a] |= bit;
        } else {
            self.mem[a] &= !bit;
        }
    }

    // ------------------------------------------------------------ master side

    /// Master configures a SyncManager (start, len, control, enabled).
    pub fn master_sm(&mut self, n: u8, start: u16, len: u16, control: u8, enable: bool) {
        let mut cfg = self.sm(n);
        cfg.start = start;
        cfg.len = len;
        cfg.control = control;
        cfg.activate = (cfg.activate & !1) | u8::from(enable);
        self.set_sm(n, cfg);
    }

    pub fn master_al_control(&mut self, value: u16) {
        self.set_u16(reg::AL_CONTROL, value);
        self.raise(event::AL_CONTROL);
    }

    pub fn al_status(&self) -> (u16, u16) {
        (
            self.u16_at(reg::AL_STATUS),
            self.u16_at(reg::AL_STATUS_CODE),
        )
    }

    /// Master writes the whole SM0 mailbox; false if it is still full.
    pub fn master_write_mailbox(&mut self, frame: &[u8]) -> bool {
        let sm = self.sm(0);
        if sm.mailbox_full() || !sm.enabled() {
            return false;
        }
        let start = usize::from(sm.start);
        let len = usize::from(sm.len);
        self.mem[start..start + len].fill(0);
        let n = frame.len().min(len);
        self.mem[start..start + n].copy_from_slice(&frame[..n]);
        self.set_sm_status_bit(0, 0x08, true);
        self.raise(event::sm(0));
        true
    }

    /// Master reads SM1 if full.
    #[cfg(test)]
    pub fn master_read_mailbox(&mut self) -> Option<std::vec::Vec<u8>> {
        let mut data = std::vec![0u8; usize::from(self.sm(1).len)];
        self.master_read_mailbox_into(&mut data).map(|_| data)
    }

    /// Master reads SM1 into `out` (up to its length) if full; returns the SM1 length.
    pub fn master_read_mailbox_into(&mut self, out: &mut [u8]) -> Option<usize> {
        let sm = self.sm(1);
        if !sm.mailbox_full() {
            return None;
        }
        let start = usize::from(sm.start);
        let len = usize::from(sm.len);
        let n = len.min(out.len());
        out[..n].copy_from_slice(&self.mem[start..start + n]);
        self.set_sm_status_bit(1, 0x08, false);
        self.raise(event::sm(1));
        Some(len)
    }

    /// Master toggles the SM1 repeat request.
    pub fn master_repeat_request(&mut self) {
        let a = usize::from(reg::SM_BASE) + 8 + 6;
        self.mem[a] ^= 0x02;
        self.raise(event::SM_ACTIVATION);
    }

    /// Master writes the outputs (SM2, 3-buffer): the PDI reads the newest complete buffer.
    pub fn master_write_outputs(&mut self, data: &[u8]) {
        let sm = self.sm(2);
        let start = usize::from(sm.start);
        let n = data.len().min(usize::from(sm.len));
        self.mem[start..start + n].copy_from_slice(&data[..n]);
        self.raise(event::sm(2));
    }

    /// Master reads the inputs (SM3).
    #[cfg(test)]
    pub fn master_read_inputs(&self) -> std::vec::Vec<u8> {
        let sm = self.sm(3);
        let start = usize::from(sm.start);
        self.mem[start..start + usize::from(sm.len)].to_vec()
    }

    pub fn master_dc(&mut self, activation: u8, sync0_cycle_ns: u32) {
        self.mem[usize::from(reg::DC_ACTIVATION)] = activation;
        let a = usize::from(reg::DC_SYNC0_CYCLE);
        self.mem[a..a + 4].copy_from_slice(&sync0_cycle_ns.to_le_bytes());
    }

    pub fn expire_watchdog(&mut self) {
        self.set_u16(reg::WD_STATUS_PD, 0);
        self.raise(event::WATCHDOG);
    }

    // ------------------------------------------------------------ PDI side effects

    fn after_read(&mut self, addr: usize, len: usize) {
        let end = addr + len;
        let covers = |a: usize| a >= addr && a < end;
        if covers(usize::from(reg::AL_CONTROL)) {
            self.clear(event::AL_CONTROL);
        }
        if covers(usize::from(reg::WD_STATUS_PD)) {
            self.clear(event::WATCHDOG);
        }
        for n in 0..4u8 {
            if covers(usize::from(reg::SM_BASE) + 8 * usize::from(n) + 6) {
                self.clear(event::SM_ACTIVATION);
            }
        }
        for n in [0u8, 2] {
            let sm = self.sm(n);
            if !sm.enabled() || sm.len == 0 {
                continue;
            }
            let start = usize::from(sm.start);
            let last = start + usize::from(sm.len) - 1;
            if covers(start) {
                self.clear(event::sm(n));
            }
            if n == 0 && covers(last) {
                self.set_sm_status_bit(0, 0x08, false);
            }
        }
    }

    fn after_write(&mut self, addr: usize, len: usize) {
        let end = addr + len;
        let covers = |a: usize| a >= addr && a < end;
        for n in 0..4u8 {
            // PDI control b0: deactivating a SyncManager empties its buffer.
            let pdi_control = usize::from(reg::SM_BASE) + 8 * usize::from(n) + 7;
            if covers(pdi_control) && self.mem[pdi_control] & SmConfig::PDI_DEACTIVATE != 0 {
                self.set_sm_status_bit(n, SmConfig::STATUS_MAILBOX_FULL, false);
            }
        }
        for n in [1u8, 3] {
            let sm = self.sm(n);
            if !sm.enabled() || sm.len == 0 {
                continue;
            }
            let start = usize::from(sm.start);
            let last = start + usize::from(sm.len) - 1;
            if covers(start) {
                self.clear(event::sm(n));
            }
            if n == 1 && covers(last) {
                self.set_sm_status_bit(1, 0x08, true);
            }
        }
    }
}

impl EscPort for FakeEsc {
    type Error = BusError;

    fn read(&mut self, addr: u16, buf: &mut [u8]) -> Result<u32, BusError> {
        if core::mem::take(&mut self.fail_next) {
            return Err(BusError);
        }
        let events = self.events_word();
        let a = usize::from(addr);
        let src = self.mem.get(a..a + buf.len()).ok_or(BusError)?;
        buf.copy_from_slice(src);
        self.reads += 1;
        if a < 0x0880 && a + buf.len() > 0x0800 {
            self.sm_register_reads += 1;
        }
        self.after_read(a, buf.len());
        Ok(events)
    }

    fn write(&mut self, addr: u16, data: &[u8]) -> Result<u32, BusError> {
        if core::mem::take(&mut self.fail_next) {
            return Err(BusError);
        }
        let events = self.events_word();
        let a = usize::from(addr);
        // Registers the PDI cannot write.
        if a < 0x1000
            && ![0x0130usize, 0x0134, 0x0204].contains(&a)
            && !(0x0800..0x0880).contains(&a)
        {
            return Err(BusError);
        }
        let dst = self.mem.get_mut(a..a + data.len()).ok_or(BusError)?;
        dst.copy_from_slice(data);
        self.writes += 1;
        self.after_write(a, data.len());
        Ok(events)
    }
}
