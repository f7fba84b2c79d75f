//! A software ET1100: register file, 8 KB process RAM, 8 FMMUs, 8 SyncManagers,
//! AL registers and events, SII EEPROM interface, distributed clocks and the
//! process-data watchdog.
//!
//! The model has two sides, as the chip has: the EtherCAT side (frames, see
//! [`Esc::process_frame`]) and the PDI side (the SPI front end in [`crate::models::spi`], the
//! 16-bit µC front end in [`parallel`] and the direct [`Esc::pdi_read`]/[`Esc::pdi_write`]
//! helpers). Every access goes through one
//! routine, [`Esc::access`], which applies register write masks, read/write side effects
//! and the SyncManager buffer rules (Beckhoff ESC datasheet Section I chapter 8).

pub mod parallel;
pub mod regs;

mod dc;
mod fmmu;
mod frame;
mod sii;
mod sm;

pub use dc::{sync1_period, Sync0Fault, SyncEdge, SyncSignal};
pub use frame::{cmd, parse_frame, FrameBuilder, ParsedDatagram, ETHERTYPE_ECAT};
pub use sii::{check_config_area, sii_crc8, SiiConfigError};

use regs::al_event;

/// Which side of the ESC performs an access.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// The EtherCAT side (datagrams from the master).
    Ecat,
    /// The process data interface (the microcontroller).
    Pdi,
}

/// The kind of one access.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Op {
    /// Read: the buffer is overwritten with ESC data.
    Read,
    /// Broadcast read: ESC data is ORed into the buffer.
    ReadOr,
    /// Write: the buffer is stored.
    Write,
    /// Read and write at once: the old data is returned, the buffer's data is stored.
    ReadWrite,
    /// Broadcast read-write: ORed read, write of the incoming data.
    ReadOrWrite,
}

impl Op {
    fn reads(self) -> bool {
        !matches!(self, Op::Write)
    }
    fn writes(self) -> bool {
        matches!(self, Op::Write | Op::ReadWrite | Op::ReadOrWrite)
    }
    fn ors(self) -> bool {
        matches!(self, Op::ReadOr | Op::ReadOrWrite)
    }
}

/// Result of one access: whether any byte was read and whether any byte was written.
/// The working counter is derived from it ("at least one byte" rule).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AccessResult {
    /// At least one byte was read.
    pub read: bool,
    /// At least one byte was written.
    pub written: bool,
}

impl AccessResult {
    fn merge(&mut self, other: AccessResult) {
        self.read |= other.read;
        self.written |= other.written;
    }
}

/// Construction parameters of the model.
#[derive(Clone, Debug)]
pub struct EscConfig {
    /// SII EEPROM image (bytes, little-endian words).
    pub sii: Vec<u8>,
    /// Virtual time one EEPROM command keeps 0x0502 bit 15 (busy) set.
    pub eeprom_busy_ns: u64,
    /// Local DC clock value at virtual time 0 (the ESC's power-on counter).
    pub dc_local_start_ns: u64,
    /// Build number reported at 0x0002.
    pub build: u16,
    /// EEPROM reads return 8 bytes (0x0502 b6 = 1, as the ET1100) instead of 4.
    pub eeprom_read_8: bool,
    /// Fault switch: virtual time the ESC takes to load its configuration from the EEPROM
    /// after power-up (0: loaded at once). While it loads, 0x0502 shows busy (b15) and
    /// "not loaded" (b12), and the PDI is not operational.
    pub eeprom_load_ns: u64,
}

impl EscConfig {
    /// A configuration with the given SII image and defaults otherwise.
    pub fn new(sii: Vec<u8>) -> Self {
        Self {
            sii,
            eeprom_busy_ns: 20_000,
            dc_local_start_ns: 1_000_000,
            build: 0x0003,
            eeprom_read_8: true,
            eeprom_load_ns: 0,
        }
    }
}

/// Hooks that run after an access completed (multi-byte registers are acted upon
/// only once all of their bytes were written, as the chip does per access).
#[derive(Default)]
struct Pending {
    al_control_written: bool,
    eeprom_command: Option<Side>,
    dc_latch_rx: bool,
    dc_system_time: [Option<u8>; 8],
    dc_activation: bool,
    sm_activate: [Option<u8>; 8],
    sm_pdi_control: [bool; 8],
    al_status_written: bool,
}

/// The ET1100 model.
pub struct Esc {
    mem: Vec<u8>,
    now_ns: u64,
    cfg: EscConfig,
    sii: sii::SiiState,
    sms: [sm::SmState; 8],
    wd: Watchdog,
    dc: dc::DcState,
    pending: Pending,
    /// Frames processed.
    pub frames: u64,
    /// Counters of the SPI front end.
    pub spi_stats: crate::models::spi::SpiStats,
    /// Record every SPI transaction into `spi_log`.
    pub spi_record: bool,
    /// Recorded SPI transactions (when `spi_record` is set).
    pub spi_log: Vec<crate::models::spi::SpiRecord>,
    /// Faults to inject into SPI transactions (none unless a test arms one).
    pub spi_faults: crate::models::spi::SpiFaults,
    /// A fault of the SYNC0 line to the MCU (none unless a test sets one).
    pub sync0_fault: Option<Sync0Fault>,
    /// The master's AL control writes and the slave's AL status writes, in order, with
    /// their times: how long the slave takes for each state change (the peer bench).
    pub al_log: Vec<AlWrite>,
    /// Record in `pdi_buffer_writes` each buffered SyncManager buffer the PDI completes.
    pub record_pdi_buffer_writes: bool,
    /// The buffered SyncManager buffers the PDI completed (when recorded): (SyncManager,
    /// time of the last byte, ns). Where the inputs were in SM3 after a SYNC0 edge: the
    /// slave's input calc and copy time (0x1C33:06).
    pub pdi_buffer_writes: Vec<(u8, u64)>,
}

/// An AL control write by the master or an AL status write by the slave.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AlWrite {
    /// Virtual time (ns).
    pub time_ns: u64,
    /// [`Side::Ecat`]: AL control (0x0120); [`Side::Pdi`]: AL status (0x0130).
    pub side: Side,
    /// The register's value after the write.
    pub value: u16,
}

#[derive(Default)]
struct Watchdog {
    /// Virtual time of the last trigger, when armed.
    last_trigger: Option<u64>,
}

impl Esc {
    /// Creates an ESC in its power-on state with the SII image loaded.
    pub fn new(cfg: EscConfig) -> Self {
        let mut esc = Self {
            mem: vec![0; regs::MEM_SIZE],
            now_ns: 0,
            sii: sii::SiiState::new(cfg.sii.clone()),
            cfg,
            sms: Default::default(),
            wd: Watchdog::default(),
            dc: dc::DcState::default(),
            pending: Pending::default(),
            frames: 0,
            spi_stats: Default::default(),
            spi_record: false,
            spi_log: Vec::new(),
            spi_faults: Default::default(),
            sync0_fault: None,
            al_log: Vec::new(),
            record_pdi_buffer_writes: false,
            pdi_buffer_writes: Vec::new(),
        };
        esc.power_on();
        esc
    }

    fn power_on(&mut self) {
        self.mem.iter_mut().for_each(|b| *b = 0);
        self.mem[regs::TYPE as usize] = 0x11;
        self.mem[regs::REVISION as usize] = 0x00;
        self.set_u16(regs::BUILD, self.cfg.build);
        self.mem[regs::FMMU_COUNT as usize] = 8;
        self.mem[regs::SM_COUNT as usize] = 8;
        self.mem[regs::RAM_SIZE as usize] = 8;
        // Ports 0 and 1 MII.
        self.mem[regs::PORT_DESCRIPTOR as usize] = 0x0F;
        // DC (b2), 64-bit DC (b3), enhanced link detection MII (b6), separate FCS error
        // handling (b7), enhanced DC SYNC activation (b8).
        self.set_u16(regs::FEATURES, 0x01CC);
        // DL control reset: forwarding rule, auto loop on all ports.
        self.set_u32(regs::DL_CONTROL, 0x0000_0001);
        self.set_u16(regs::AL_STATUS, 0x0001);
        self.set_u16(regs::AL_CONTROL, 0x0001);
        self.set_u32(regs::AL_EVENT_MASK, 0x00FF_FF0F);
        self.set_u16(regs::WD_DIVIDER, 0x09C2);
        self.set_u16(regs::WD_TIME_PDI, 1000);
        self.set_u16(regs::WD_TIME_PD, 1000);
        self.mem[regs::WD_STATUS_PD as usize] = 0x01;
        self.sms = Default::default();
        self.wd = Watchdog::default();
        self.dc = dc::DcState::default();
        if self.cfg.eeprom_load_ns == 0 {
            self.sii_load_config();
        } else {
            self.sii_start_loading(self.cfg.eeprom_load_ns);
        }
        self.update_dl_status();
    }

    /// The construction parameters.
    pub fn config(&self) -> &EscConfig {
        &self.cfg
    }

    // ---------------------------------------------------------------- time

    /// Current virtual time of the model in ns.
    pub fn now_ns(&self) -> u64 {
        self.now_ns
    }

    /// Advances virtual time by `ns`, returning the SYNC0/SYNC1 edges that occurred
    /// (in order). EEPROM commands complete and the watchdog expires on the way.
    pub fn advance(&mut self, ns: u64) -> Vec<SyncEdge> {
        let target = self.now_ns + ns;
        let mut edges = Vec::new();
        loop {
            match self.dc_next_edge_time() {
                Some(t) if t <= target => {
                    self.set_time(t);
                    self.dc_fire(&mut edges);
                }
                _ => break,
            }
        }
        self.set_time(target);
        edges
    }

    /// Virtual time of the next SYNC0/SYNC1 edge, if the cyclic unit runs.
    pub fn next_sync_edge_ns(&self) -> Option<u64> {
        self.dc_next_edge_time()
    }

    fn set_time(&mut self, t: u64) {
        if t > self.now_ns {
            self.now_ns = t;
        }
        self.update();
    }

    /// Completes whatever timed operations are due at the current virtual time.
    fn update(&mut self) {
        self.sii_update();
        self.wd_update();
    }

    // ---------------------------------------------------------------- raw memory

    /// Raw read without side effects (for tests and the harness).
    pub fn peek(&self, addr: u16, buf: &mut [u8]) {
        for (i, b) in buf.iter_mut().enumerate() {
            *b = self.mem.get(addr as usize + i).copied().unwrap_or(0);
        }
    }

    /// Raw u8 read without side effects.
    pub fn peek_u8(&self, addr: u16) -> u8 {
        self.mem.get(addr as usize).copied().unwrap_or(0)
    }

    /// Raw u16 read without side effects.
    pub fn peek_u16(&self, addr: u16) -> u16 {
        let mut b = [0; 2];
        self.peek(addr, &mut b);
        u16::from_le_bytes(b)
    }

    /// Raw u32 read without side effects.
    pub fn peek_u32(&self, addr: u16) -> u32 {
        let mut b = [0; 4];
        self.peek(addr, &mut b);
        u32::from_le_bytes(b)
    }

    /// Raw write without side effects (test set-up only).
    pub fn poke(&mut self, addr: u16, data: &[u8]) {
        for (i, b) in data.iter().enumerate() {
            if let Some(m) = self.mem.get_mut(addr as usize + i) {
                *m = *b;
            }
        }
    }

    fn set_u16(&mut self, addr: u16, v: u16) {
        self.poke(addr, &v.to_le_bytes());
    }

    fn set_u32(&mut self, addr: u16, v: u32) {
        self.poke(addr, &v.to_le_bytes());
    }

    fn set_u64(&mut self, addr: u16, v: u64) {
        self.poke(addr, &v.to_le_bytes());
    }

    fn get_u64(&self, addr: u16) -> u64 {
        let mut b = [0; 8];
        self.peek(addr, &mut b);
        u64::from_le_bytes(b)
    }

    // ---------------------------------------------------------------- events

    /// AL event request register 0x0220 (u32).
    pub fn al_event_request(&self) -> u32 {
        self.peek_u32(regs::AL_EVENT_REQUEST)
    }

    /// The SPI_IRQ line (level, active = true): OR of 0x0220 & 0x0204.
    pub fn irq(&self) -> bool {
        self.al_event_request() & self.peek_u32(regs::AL_EVENT_MASK) != 0
    }

    fn set_al_event(&mut self, bits: u32) {
        let v = self.al_event_request() | bits;
        self.set_u32(regs::AL_EVENT_REQUEST, v);
    }

    fn clear_al_event(&mut self, bits: u32) {
        let v = self.al_event_request() & !bits;
        self.set_u32(regs::AL_EVENT_REQUEST, v);
    }

    fn set_ecat_event(&mut self, bits: u16) {
        let v = self.peek_u16(regs::ECAT_EVENT_REQUEST) | bits;
        self.set_u16(regs::ECAT_EVENT_REQUEST, v);
    }

    fn clear_ecat_event(&mut self, bits: u16) {
        let v = self.peek_u16(regs::ECAT_EVENT_REQUEST) & !bits;
        self.set_u16(regs::ECAT_EVENT_REQUEST, v);
    }

    /// ECAT event bits that go into the IRQ field of every datagram (0x0210 & 0x0200).
    fn ecat_irq_field(&self) -> u16 {
        self.peek_u16(regs::ECAT_EVENT_REQUEST) & self.peek_u16(regs::ECAT_EVENT_MASK)
    }

    /// Whether the PDI is operational (SII loaded with a good checksum, 0x0110 b0).
    pub fn pdi_operational(&self) -> bool {
        self.sii.loaded_ok
    }

    fn update_dl_status(&mut self) {
        // b0 PDI operational, b1 PDI watchdog ok, b2 enhanced link detection,
        // b4 link port 0; b9 communication on port 0, ports 1..3 closed (loop bits).
        let mut v: u16 = 0x0002 | 0x0004 | 0x0010 | 0x5600;
        if self.sii.loaded_ok {
            v |= 0x0001;
        }
        self.set_u16(regs::DL_STATUS, v);
    }

    // ---------------------------------------------------------------- PDI helpers

    /// Reads `buf.len()` bytes at `addr` as the PDI does in one access (all side effects).
    pub fn pdi_read(&mut self, addr: u16, buf: &mut [u8]) -> AccessResult {
        self.access(Side::Pdi, addr as u32, buf, Op::Read)
    }

    /// Writes `data` at `addr` as the PDI does in one access (all side effects).
    pub fn pdi_write(&mut self, addr: u16, data: &[u8]) -> AccessResult {
        let mut buf = data.to_vec();
        self.access(Side::Pdi, addr as u32, &mut buf, Op::Write)
    }

    /// Reads `buf.len()` bytes as the EtherCAT side would (one FPRD, without a frame).
    pub fn ecat_read(&mut self, addr: u16, buf: &mut [u8]) -> AccessResult {
        self.access(Side::Ecat, addr as u32, buf, Op::Read)
    }

    /// Writes as the EtherCAT side would (one FPWR, without a frame).
    pub fn ecat_write(&mut self, addr: u16, data: &[u8]) -> AccessResult {
        let mut buf = data.to_vec();
        self.access(Side::Ecat, addr as u32, &mut buf, Op::Write)
    }

    // ---------------------------------------------------------------- core access

    /// One access of `buf.len()` bytes at `addr` from `side`.
    ///
    /// The range is split at SyncManager buffer boundaries: SM buffers follow the
    /// mailbox / 3-buffer rules, everything else is register or RAM memory with write
    /// masks and side effects. Multi-byte register actions run after the whole access.
    pub fn access(&mut self, side: Side, addr: u32, buf: &mut [u8], op: Op) -> AccessResult {
        self.update();
        let mut result = AccessResult::default();
        let end = addr + buf.len() as u32;
        let mut pos = addr;
        let incoming = buf.to_vec();
        while pos < end {
            let i = (pos - addr) as usize;
            if let Some((n, start, len)) = self.sm_at(side, pos) {
                let seg_end = end.min(start + len);
                let seg_len = (seg_end - pos) as usize;
                let r = self.sm_access(
                    side,
                    n,
                    pos - start,
                    &mut buf[i..i + seg_len],
                    &incoming[i..i + seg_len],
                    op,
                );
                result.merge(r);
                pos = seg_end;
            } else {
                let next_sm = self.next_sm_start(side, pos).unwrap_or(u32::MAX);
                let seg_end = end.min(next_sm);
                for a in pos..seg_end {
                    let j = (a - addr) as usize;
                    if op.reads() {
                        let v = self.reg_read_byte(side, a);
                        if op.ors() {
                            buf[j] |= v;
                        } else {
                            buf[j] = v;
                        }
                    }
                    if op.writes() {
                        self.reg_write_byte(side, a, incoming[j]);
                    }
                }
                result.read |= op.reads();
                result.written |= op.writes();
                pos = seg_end;
            }
        }
        self.run_pending(side);
        if op.writes() {
            let reg = match side {
                Side::Ecat => regs::AL_CONTROL,
                Side::Pdi => regs::AL_STATUS,
            };
            if addr <= u32::from(reg) && end > u32::from(reg) {
                self.al_log.push(AlWrite {
                    time_ns: self.now_ns,
                    side,
                    value: self.peek_u16(reg),
                });
            }
        }
        result
    }

    /// Register/RAM byte read with read side effects.
    fn reg_read_byte(&mut self, side: Side, a: u32) -> u8 {
        if a as usize >= regs::MEM_SIZE {
            return 0;
        }
        let a16 = a as u16;
        match (side, a16) {
            (_, 0x0805..=0x083D) if (a16 - regs::SM_BASE) % 8 == 5 => {
                return self.sm_status((a16 - regs::SM_BASE) as usize / 8);
            }
            (Side::Pdi, regs::AL_CONTROL | 0x0121) => self.clear_al_event(al_event::AL_CONTROL),
            (Side::Ecat, regs::AL_STATUS) => self.clear_ecat_event(1 << 3),
            (Side::Pdi, regs::WD_STATUS_PD) => self.clear_al_event(al_event::WATCHDOG_PD),
            (Side::Pdi, 0x0806..=0x083E) if (a16 - regs::SM_BASE) % 8 == 6 => {
                self.clear_al_event(al_event::SM_ACTIVATION)
            }
            (Side::Pdi, regs::DC_SYNC0_STATUS) => {
                self.clear_al_event(al_event::SYNC0);
                let v = self.peek_u8(a16);
                self.mem[a as usize] = 0;
                return v;
            }
            (Side::Pdi, regs::DC_SYNC1_STATUS) => {
                self.clear_al_event(al_event::SYNC1);
                let v = self.peek_u8(a16);
                self.mem[a as usize] = 0;
                return v;
            }
            (_, 0x0910..=0x0917) => return self.dc_read_system_time_byte(side, a16),
            _ => {}
        }
        self.mem[a as usize]
    }

    /// Write mask of one register byte for one side (1 = writable bit).
    fn write_mask(&self, side: Side, a: u16) -> u8 {
        use Side::{Ecat, Pdi};
        let sync_owner_pdi = self.peek_u8(regs::DC_CYCLIC_UNIT_CONTROL) & 0x01 != 0;
        let dc_side = if sync_owner_pdi { Pdi } else { Ecat };
        let eeprom_owner = self.sii_owner();
        let sm_n = a.wrapping_sub(regs::SM_BASE) as usize / 8;
        let sm_off = a.wrapping_sub(regs::SM_BASE) % 8;
        let sm_enabled = sm_n < 8 && self.peek_u8(regs::sm(sm_n) + 6) & 0x01 != 0;
        match a {
            0x0010..=0x0011 => only(side, Ecat, 0xFF),
            0x0012..=0x0013 => only(side, Pdi, 0xFF),
            0x0020..=0x0031 | 0x0040..=0x0041 => only(side, Ecat, 0xFF),
            0x0100..=0x0103 | 0x0108..=0x0109 => only(side, Ecat, 0xFF),
            0x0120..=0x0121 => only(side, Ecat, 0xFF),
            0x0130..=0x0131 | 0x0134..=0x0135 => only(side, Pdi, 0xFF),
            0x0138..=0x0139 => only(side, Ecat, 0xFF),
            0x0200..=0x0201 => only(side, Ecat, 0xFF),
            0x0204..=0x0207 => only(side, Pdi, 0xFF),
            // Error counters: a write clears (handled before the mask).
            0x0300..=0x0313 => only(side, Ecat, 0xFF),
            0x0400..=0x0401 | 0x0410..=0x0411 | 0x0420..=0x0421 => only(side, Ecat, 0xFF),
            0x0442..=0x0443 => only(side, Ecat, 0xFF),
            regs::EEPROM_CONFIG => only(side, Ecat, 0x03),
            regs::EEPROM_PDI_ACCESS => only(side, Pdi, 0x01),
            0x0502 => only(side, eeprom_owner, 0x01),
            0x0503 => only(side, eeprom_owner, 0x07),
            0x0504..=0x050F => only(side, eeprom_owner, 0xFF),
            0x0510..=0x0517 => only(side, Ecat, 0xFF),
            // FMMU: 13 meaningful bytes per entry.
            0x0600..=0x067F if (a - regs::FMMU_BASE) % 16 < 13 => only(side, Ecat, 0xFF),
            // SM: start/length/control only while disabled; activate (ECAT), PDI control.
            0x0800..=0x083F if sm_off <= 4 && !sm_enabled => only(side, Ecat, 0xFF),
            0x0800..=0x083F if sm_off == 6 => only(side, Ecat, 0xC3),
            0x0800..=0x083F if sm_off == 7 => only(side, Pdi, 0x03),
            // 0x0900..0x0917 are handled as actions (latch / drift control), not stored.
            0x0920..=0x092B => only(side, Ecat, 0xFF),
            0x0930..=0x0931 | 0x0934..=0x0935 => only(side, Ecat, 0xFF),
            0x0980 => only(side, Ecat, 0xFF),
            regs::DC_ACTIVATION => only(side, dc_side, 0xFF),
            0x0990..=0x0997 | 0x09A0..=0x09A7 => only(side, dc_side, 0xFF),
            0x09A8..=0x09A9 => only(side, Ecat, 0xFF),
            0x0F00..=0x0F03 => only(side, Pdi, 0xFF),
            0x0F10..=0x0F1F | 0x0F80..=0x0FFF => 0xFF,
            0x1000..=0x2FFF => 0xFF,
            _ => 0,
        }
    }

    /// Register/RAM byte write with masks and side effects.
    fn reg_write_byte(&mut self, side: Side, a: u32, v: u8) {
        if a as usize >= regs::MEM_SIZE {
            return;
        }
        let a16 = a as u16;
        match (side, a16) {
            (Side::Ecat, regs::DC_RECEIVE_TIME_PORT0) => {
                self.pending.dc_latch_rx = true;
                return;
            }
            (Side::Ecat, 0x0910..=0x0917) => {
                self.pending.dc_system_time[(a16 - 0x0910) as usize] = Some(v);
                return;
            }
            (Side::Ecat, 0x0300..=0x0313) | (Side::Ecat, 0x0442..=0x0443) => {
                // Error and watchdog counters are cleared by any write.
                self.mem[a as usize] = 0;
                return;
            }
            _ => {}
        }
        let mask = self.write_mask(side, a16);
        if mask == 0 {
            return;
        }
        let old = self.mem[a as usize];
        let new = (old & !mask) | (v & mask);
        match (side, a16) {
            (Side::Ecat, regs::AL_CONTROL | 0x0121) => self.pending.al_control_written = true,
            (Side::Pdi, regs::AL_STATUS | 0x0131) => self.pending.al_status_written = true,
            (_, regs::EEPROM_CONTROL | 0x0503) => {
                self.mem[a as usize] = new;
                if a16 == 0x0503 {
                    self.pending.eeprom_command = Some(side);
                }
                return;
            }
            (_, 0x0806..=0x083E) if (a16 - regs::SM_BASE) % 8 == 6 => {
                let n = ((a16 - regs::SM_BASE) / 8) as usize;
                if self.pending.sm_activate[n].is_none() {
                    self.pending.sm_activate[n] = Some(old);
                }
            }
            (_, 0x0807..=0x083F) if (a16 - regs::SM_BASE) % 8 == 7 => {
                let n = ((a16 - regs::SM_BASE) / 8) as usize;
                self.pending.sm_pdi_control[n] = true;
            }
            (_, regs::DC_ACTIVATION) => self.pending.dc_activation = true,
            _ => {}
        }
        self.mem[a as usize] = new;
    }

    fn run_pending(&mut self, side: Side) {
        let p = std::mem::take(&mut self.pending);
        if p.al_control_written {
            self.set_al_event(al_event::AL_CONTROL);
            // Device emulation (0x0141 b0): AL control is copied into AL status.
            if self.peek_u8(regs::ESC_CONFIG) & 0x01 != 0 {
                let c = self.peek_u8(regs::AL_CONTROL) & 0x1F;
                self.mem[regs::AL_STATUS as usize] = c & 0x0F;
            }
        }
        if p.al_status_written {
            self.set_ecat_event(1 << 3);
        }
        for (n, old) in p.sm_activate.iter().enumerate() {
            if let Some(old) = old {
                self.sm_activation_written(n, *old);
            }
        }
        for (n, w) in p.sm_pdi_control.iter().enumerate() {
            if *w {
                self.sm_pdi_control_written(n);
            }
        }
        if let Some(s) = p.eeprom_command {
            self.sii_command(s);
        }
        if p.dc_latch_rx {
            self.dc_latch_receive_times();
        }
        if p.dc_system_time.iter().any(|b| b.is_some()) {
            self.dc_system_time_written(&p.dc_system_time);
        }
        if p.dc_activation {
            self.dc_activation_written();
        }
        // Mirror the SM status registers into memory (so raw peeks see them too).
        for n in 0..8 {
            let v = self.sm_status(n);
            self.mem[regs::sm(n) as usize + 5] = v;
        }
        let _ = side;
    }

    // ---------------------------------------------------------------- watchdog

    /// Process-data watchdog period in ns (0 = disabled).
    pub fn pd_watchdog_period_ns(&self) -> u64 {
        let div = self.peek_u16(regs::WD_DIVIDER) as u64;
        let time = self.peek_u16(regs::WD_TIME_PD) as u64;
        (div + 2) * 40 * time
    }

    fn wd_trigger(&mut self) {
        self.wd.last_trigger = Some(self.now_ns);
        self.mem[regs::WD_STATUS_PD as usize] |= 0x01;
    }

    fn wd_update(&mut self) {
        let period = self.pd_watchdog_period_ns();
        if let Some(t) = self.wd.last_trigger {
            if period != 0 && self.now_ns >= t + period {
                self.wd.last_trigger = None;
                self.mem[regs::WD_STATUS_PD as usize] &= !0x01;
                let c = self.mem[regs::WD_COUNTER_PD as usize];
                self.mem[regs::WD_COUNTER_PD as usize] = c.saturating_add(1);
                self.set_al_event(al_event::WATCHDOG_PD);
            }
        }
    }
}

/// `mask` when `side` is `owner`, else 0.
fn only(side: Side, owner: Side, mask: u8) -> u8 {
    if side == owner {
        mask
    } else {
        0
    }
}
