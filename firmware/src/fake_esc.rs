//! A register-file ESC for the host tests: a PDI of the `et1100` driver ([`Pdi`]), so the
//! application reaches it through `Et1100<FakeEsc>` exactly as it reaches the board's SPI
//! PDI, and a master side through the `master_*` methods. It has the ET1100 behaviour the
//! application relies on (mailbox full/empty on the last byte, 3-buffer outputs,
//! read-to-clear events, the registers the PDI may write), without SPI bytes: every access
//! returns the event bits as the SPI address phase would.
//!
//! Also used outside the crate's tests (feature `fake-esc`): the Cortex-M3 benchmark
//! (`xtask/bench-cm3`) runs the application's hot paths against it in RAM.

use et1100::{AlEvents, Error, Et1100, Pdi, Register, SyncManager};

/// The register file covers the registers and the first 4 KB of process RAM.
const SIZE: usize = 0x2000;
/// SyncManagers with behaviour (mailboxes SM0/SM1, process data SM2/SM3).
const SYNC_MANAGERS: u8 = 4;

const fn at(r: Register) -> usize {
    r.addr() as usize
}

/// The address of SyncManager `n`'s register byte at `offset`.
const fn sm_byte(n: u8, offset: u16) -> usize {
    at(Register::SyncManager0) + 8 * n as usize + offset as usize
}

/// The register file (0x0000..0x2000) with the PDI-side effects of the ET1100.
pub struct FakeEsc {
    /// ESC memory.
    pub mem: [u8; SIZE],
    /// Fail the next PDI access with [`BusError`].
    pub fail_next: bool,
    /// PDI writes so far.
    pub writes: usize,
    /// PDI reads so far (any address, and event reads: an SPI NOP is an access too).
    pub reads: usize,
    /// PDI reads touching the SyncManager registers (0x0800..0x0880).
    pub sm_register_reads: usize,
    /// Bytes of the longest PDI access (read or write) to process RAM (0x1000..).
    pub longest_ram_access: usize,
    /// Bits flipped on the way, as the SPI can: `(address, byte offset, XOR mask, reads)`
    /// for the next `reads` reads starting at the address, the mask rotated by one bit from
    /// read to read (the MCU gets them wrong, each differently; the register file keeps the
    /// data right).
    pub corrupt_next_read: Option<(u16, usize, u8, u8)>,
    /// The same for the next write starting at the address (the register file gets it
    /// wrong).
    pub corrupt_next_write: Option<(u16, usize, u8)>,
}

/// A PDI access outside the register file or to a register the PDI cannot write.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
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
            mem: [0; SIZE],
            fail_next: false,
            writes: 0,
            reads: 0,
            sm_register_reads: 0,
            longest_ram_access: 0,
            corrupt_next_read: None,
            corrupt_next_write: None,
        };
        esc.set_u16(Register::AlStatus.addr(), 1);
        esc.set_u16(Register::WatchdogStatusProcessData.addr(), 1);
        for n in 0..SYNC_MANAGERS {
            // Last buffer: none written yet.
            esc.mem[sm_byte(n, SyncManager::STATUS_OFFSET)] = 0x30;
        }
        esc
    }

    /// The ESC as the application reaches it: the `et1100` driver on this PDI.
    pub fn driver(&mut self) -> Et1100<&mut Self> {
        Et1100::new(self)
    }

    pub fn u16_at(&self, addr: u16) -> u16 {
        let a = usize::from(addr);
        u16::from_le_bytes([self.mem[a], self.mem[a + 1]])
    }

    pub fn u32_at(&self, addr: u16) -> u32 {
        let a = usize::from(addr);
        u32::from_le_bytes([
            self.mem[a],
            self.mem[a + 1],
            self.mem[a + 2],
            self.mem[a + 3],
        ])
    }

    pub fn set_u16(&mut self, addr: u16, v: u16) {
        let a = usize::from(addr);
        self.mem[a..a + 2].copy_from_slice(&v.to_le_bytes());
    }

    fn set_u32(&mut self, addr: u16, v: u32) {
        let a = usize::from(addr);
        self.mem[a..a + 4].copy_from_slice(&v.to_le_bytes());
    }

    /// The AL event request register (0x0220).
    pub fn event_request(&self) -> AlEvents {
        AlEvents::from_bits_retain(self.u32_at(Register::AlEventRequest.addr()))
    }

    /// The AL event mask the PDI wrote (0x0204).
    pub fn event_mask(&self) -> AlEvents {
        AlEvents::from_bits_retain(self.u32_at(Register::AlEventMask.addr()))
    }

    pub fn raise(&mut self, events: AlEvents) {
        let v = self.event_request() | events;
        self.set_u32(Register::AlEventRequest.addr(), v.bits());
    }

    fn clear(&mut self, events: AlEvents) {
        let v = self.event_request() - events;
        self.set_u32(Register::AlEventRequest.addr(), v.bits());
    }

    pub fn sm(&self, n: u8) -> SyncManager {
        let a = sm_byte(n, 0);
        let mut b = [0u8; 8];
        b.copy_from_slice(&self.mem[a..a + 8]);
        SyncManager::from_bytes(b)
    }

    pub fn set_sm(&mut self, n: u8, sm: SyncManager) {
        let a = sm_byte(n, 0);
        self.mem[a..a + 8].copy_from_slice(&sm.to_bytes());
    }

    fn set_mailbox_full(&mut self, n: u8, on: bool) {
        let a = sm_byte(n, SyncManager::STATUS_OFFSET);
        if on {
            self.mem[a] |= SyncManager::STATUS_MAILBOX_FULL;
        } else {
            self.mem[a] &= !SyncManager::STATUS_MAILBOX_FULL;
        }
    }

    // ------------------------------------------------------------ master side

    /// Master configures a SyncManager (start, len, control, enabled). A disabled
    /// SyncManager's buffer is empty, as on the ESC (a mailbox loses a frame it held).
    pub fn master_sm(&mut self, n: u8, start: u16, len: u16, control: u8, enable: bool) {
        if !enable {
            self.set_mailbox_full(n, false);
        }
        let mut sm = self.sm(n);
        sm.start = start;
        sm.length = len;
        sm.control = control;
        sm.activate = (sm.activate & !SyncManager::ACTIVATE_ENABLE)
            | if enable {
                SyncManager::ACTIVATE_ENABLE
            } else {
                0
            };
        self.set_sm(n, sm);
    }

    pub fn master_al_control(&mut self, value: u16) {
        self.set_u16(Register::AlControl.addr(), value);
        self.raise(AlEvents::AL_CONTROL);
    }

    pub fn al_status(&self) -> (u16, u16) {
        (
            self.u16_at(Register::AlStatus.addr()),
            self.u16_at(Register::AlStatusCode.addr()),
        )
    }

    /// Master writes the whole SM0 mailbox; false if it is still full.
    pub fn master_write_mailbox(&mut self, frame: &[u8]) -> bool {
        let sm = self.sm(0);
        if sm.mailbox_full() || !sm.enabled() {
            return false;
        }
        let start = usize::from(sm.start);
        let len = usize::from(sm.length);
        self.mem[start..start + len].fill(0);
        let n = frame.len().min(len);
        self.mem[start..start + n].copy_from_slice(&frame[..n]);
        self.set_mailbox_full(0, true);
        self.raise(AlEvents::SM0);
        true
    }

    /// Master reads SM1 if full.
    #[cfg(test)]
    pub fn master_read_mailbox(&mut self) -> Option<std::vec::Vec<u8>> {
        let mut data = std::vec![0u8; usize::from(self.sm(1).length)];
        self.master_read_mailbox_into(&mut data).map(|_| data)
    }

    /// Master reads SM1 into `out` (up to its length) if full; returns the SM1 length.
    pub fn master_read_mailbox_into(&mut self, out: &mut [u8]) -> Option<usize> {
        let sm = self.sm(1);
        if !sm.mailbox_full() {
            return None;
        }
        let start = usize::from(sm.start);
        let len = usize::from(sm.length);
        let n = len.min(out.len());
        out[..n].copy_from_slice(&self.mem[start..start + n]);
        self.set_mailbox_full(1, false);
        self.raise(AlEvents::SM1);
        Some(len)
    }

    /// Master toggles the SM1 repeat request.
    pub fn master_repeat_request(&mut self) {
        self.mem[sm_byte(1, SyncManager::ACTIVATE_OFFSET)] ^= SyncManager::ACTIVATE_REPEAT_REQUEST;
        self.raise(AlEvents::SM_ACTIVATION);
    }

    /// Master writes the outputs (SM2, 3-buffer): the PDI reads the newest complete buffer.
    pub fn master_write_outputs(&mut self, data: &[u8]) {
        let sm = self.sm(2);
        let start = usize::from(sm.start);
        let n = data.len().min(usize::from(sm.length));
        self.mem[start..start + n].copy_from_slice(&data[..n]);
        self.raise(AlEvents::SM2);
    }

    /// Master reads the inputs (SM3).
    #[cfg(test)]
    pub fn master_read_inputs(&self) -> std::vec::Vec<u8> {
        let sm = self.sm(3);
        let start = usize::from(sm.start);
        self.mem[start..start + usize::from(sm.length)].to_vec()
    }

    pub fn master_dc(&mut self, activation: u8, sync0_cycle_ns: u32) {
        self.mem[at(Register::DcActivation)] = activation;
        self.set_u32(Register::DcSync0CycleTime.addr(), sync0_cycle_ns);
    }

    pub fn expire_watchdog(&mut self) {
        self.set_u16(Register::WatchdogStatusProcessData.addr(), 0);
        self.raise(AlEvents::WATCHDOG);
    }

    // ------------------------------------------------------------ PDI side effects

    fn after_read(&mut self, addr: usize, len: usize) {
        let end = addr + len;
        let covers = |a: usize| a >= addr && a < end;
        if covers(at(Register::AlControl)) {
            self.clear(AlEvents::AL_CONTROL);
        }
        if covers(at(Register::WatchdogStatusProcessData)) {
            self.clear(AlEvents::WATCHDOG);
        }
        for n in 0..SYNC_MANAGERS {
            if covers(sm_byte(n, SyncManager::ACTIVATE_OFFSET)) {
                self.clear(AlEvents::SM_ACTIVATION);
            }
        }
        for n in [0u8, 2] {
            let sm = self.sm(n);
            let Some(last) = sm.last_address().filter(|_| sm.enabled()) else {
                continue;
            };
            if covers(usize::from(sm.start)) {
                self.clear(AlEvents::sm(n));
            }
            if n == 0 && covers(usize::from(last)) {
                self.set_mailbox_full(0, false);
            }
        }
    }

    fn after_write(&mut self, addr: usize, len: usize) {
        let end = addr + len;
        let covers = |a: usize| a >= addr && a < end;
        for n in 0..SYNC_MANAGERS {
            // PDI control b0: deactivating a SyncManager empties its buffer.
            let pdi_control = sm_byte(n, SyncManager::PDI_CONTROL_OFFSET);
            if covers(pdi_control) && self.mem[pdi_control] & SyncManager::PDI_DEACTIVATE != 0 {
                self.set_mailbox_full(n, false);
            }
        }
        for n in [1u8, 3] {
            let sm = self.sm(n);
            let Some(last) = sm.last_address().filter(|_| sm.enabled()) else {
                continue;
            };
            if covers(usize::from(sm.start)) {
                self.clear(AlEvents::sm(n));
            }
            if n == 1 && covers(usize::from(last)) {
                self.set_mailbox_full(1, true);
            }
        }
    }

    /// The start of an access: the injected failure, the range check of the driver's
    /// [`Pdi`] contract, the event bits of the address phase.
    fn begin(&mut self, addr: u16, len: usize) -> Result<(usize, AlEvents), Error<BusError>> {
        if core::mem::take(&mut self.fail_next) {
            return Err(Error::Bus(BusError));
        }
        let a = usize::from(addr);
        if len == 0 || a + len > 0x1_0000 {
            return Err(Error::OutOfRange);
        }
        if a >= at(Register::ProcessRam) {
            self.longest_ram_access = self.longest_ram_access.max(len);
        }
        if a + len > SIZE {
            return Err(Error::Bus(BusError));
        }
        Ok((a, self.event_request()))
    }
}

/// The 16 SyncManager register blocks (0x0800..0x0880).
const SM_REGISTERS: core::ops::Range<usize> = sm_byte(0, 0)..sm_byte(16, 0);

/// Registers below the process RAM the PDI may write, besides the SyncManager blocks (for
/// their PDI control bytes; the register file does not narrow that further).
const PDI_WRITABLE: [Register; 3] = [
    Register::AlStatus,
    Register::AlStatusCode,
    Register::AlEventMask,
];

impl Pdi for FakeEsc {
    type BusError = BusError;

    fn read(&mut self, addr: u16, buf: &mut [u8]) -> Result<AlEvents, Error<BusError>> {
        let (a, events) = self.begin(addr, buf.len())?;
        buf.copy_from_slice(&self.mem[a..a + buf.len()]);
        if let Some((at, i, mask, reads)) = self.corrupt_next_read {
            if at == addr {
                self.corrupt_next_read =
                    (reads > 1).then_some((at, i, mask.rotate_left(1), reads - 1));
                if let Some(b) = buf.get_mut(i) {
                    *b ^= mask;
                }
            }
        }
        self.reads += 1;
        if a < SM_REGISTERS.end && a + buf.len() > SM_REGISTERS.start {
            self.sm_register_reads += 1;
        }
        self.after_read(a, buf.len());
        Ok(events)
    }

    fn write(&mut self, addr: u16, data: &[u8]) -> Result<AlEvents, Error<BusError>> {
        let (a, events) = self.begin(addr, data.len())?;
        if a < at(Register::ProcessRam)
            && !PDI_WRITABLE.iter().any(|r| at(*r) == a)
            && !SM_REGISTERS.contains(&a)
        {
            return Err(Error::Bus(BusError));
        }
        self.mem[a..a + data.len()].copy_from_slice(data);
        if let Some((at, i, mask)) = self.corrupt_next_write {
            if at == addr && i < data.len() {
                self.corrupt_next_write = None;
                self.mem[a + i] ^= mask;
            }
        }
        self.writes += 1;
        self.after_write(a, data.len());
        Ok(events)
    }

    /// The event bits alone: counted as a read (an SPI NOP is an access).
    fn events(&mut self) -> Result<AlEvents, Error<BusError>> {
        if core::mem::take(&mut self.fail_next) {
            return Err(Error::Bus(BusError));
        }
        self.reads += 1;
        Ok(self.event_request())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn disabling_a_mailbox_empties_it() {
        let mut esc = FakeEsc::new();
        esc.master_sm(0, 0x1000, 128, 0x26, true);
        assert!(esc.master_write_mailbox(&[1, 2, 3]));
        assert!(esc.sm(0).mailbox_full());
        esc.master_sm(0, 0x1000, 128, 0x26, false);
        assert!(!esc.sm(0).mailbox_full());
        esc.master_sm(0, 0x1000, 128, 0x26, true);
        assert!(esc.master_write_mailbox(&[4]));
    }
}
