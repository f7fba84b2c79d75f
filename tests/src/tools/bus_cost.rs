//! PDI bus cost of the firmware's slave application: SPI transactions and bytes per
//! process-data cycle, per mailbox SDO exchange and per ESM transition, counted on the
//! byte-exact SPI front end ([`crate::models::spi::SpiStats`]) while a scripted master drives the
//! board's ESC from the EtherCAT side (register writes and reads without frames, so only the
//! PDI side is counted).
//!
//! The minimum of each operation is what the ET1100 SPI protocol cannot do without
//! (hardware-facts 1.2): per access 2 address bytes (2-byte addressing below 0x2000), one
//! wait-state byte per read (command 3), and the data bytes the operation must move. For a
//! process-data cycle that is the outputs read from SM2 and the inputs written to SM3 (the
//! AL events come for free in the address phase of those accesses); for a mailbox exchange
//! the request read from SM0 and the reply written to SM1, each up to the buffer's last byte
//! (reading/writing the last byte is what frees/fills an ESC mailbox).

use crate::models::esc::regs;
use crate::models::spi::SpiRecord;
use crate::rig::board::{BoardConfig, VirtualBoard};
use crate::tools::sim::Target;
use firmware::products::analog_io::device::DEVICE;

/// Mailbox layout the scripted master configures (the device's SII values).
const MBX_OUT: u16 = 0x1000;
const MBX_IN: u16 = 0x1080;
const MBX_LEN: u16 = 128;
/// The process-data buffers, where the device's SII puts them.
const PD_OUT: u16 = DEVICE.sync_managers[2].start;
const PD_IN: u16 = DEVICE.sync_managers[3].start;

/// An object longer than the mailbox data area (the module description string of
/// `firmware::products::analog_io::od`), uploaded in segments.
const SEGMENTED_UPLOAD_INDEX: u16 = 0x2001;

/// Address bytes of one access (2-byte addressing).
pub const ADDRESS_BYTES: u64 = 2;
/// Wait-state bytes of one read (command 3, read with wait state).
pub const READ_WAIT_BYTES: u64 = 1;

/// The cost of one operation on the PDI.
#[derive(Clone, Debug, PartialEq)]
pub struct BusCost {
    /// What was measured.
    pub name: String,
    /// How many times it ran (the figures are per run, rounded to the nearest byte).
    pub runs: u64,
    /// SPI transactions (SPI_SEL low periods) per run.
    pub transactions: f64,
    /// Bytes clocked per run.
    pub bytes: f64,
    /// The protocol minimum per run (payload + mandatory address/wait bytes).
    pub minimum_bytes: u64,
    /// How the bytes split up, per run: (address, wait, read data, write data).
    pub split: (f64, f64, f64, f64),
    /// The accesses of one run, as (command, address, data bytes), for the cause analysis.
    pub accesses: Vec<(&'static str, u16, usize)>,
    /// Accesses per run by kind, over all runs (for the CPU model, which costs a NOP, a
    /// read and a write of the driver differently).
    pub kinds: AccessCounts,
}

/// Accesses by kind, per run.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AccessCounts {
    /// NOPs (the AL event bits alone).
    pub nops: f64,
    /// Reads.
    pub reads: f64,
    /// Writes.
    pub writes: f64,
}

impl AccessCounts {
    fn of(log: &[SpiRecord], runs: u64) -> Self {
        let count = |kind: &str| {
            log.iter().filter(|r| decode(r).0 == kind).count() as f64 / runs.max(1) as f64
        };
        Self {
            nops: count("nop"),
            reads: count("read"),
            writes: count("write"),
        }
    }

    fn per(self, n: f64) -> Self {
        Self {
            nops: self.nops / n,
            reads: self.reads / n,
            writes: self.writes / n,
        }
    }
}

/// All figures of one scripted run.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BusReport {
    /// Process-data cycle (DC SYNC0), ESM transitions, SDO exchanges.
    pub costs: Vec<BusCost>,
    /// Output/input bytes of the process data (SM2, SM3).
    pub process_data_bytes: (u16, u16),
    /// DC cycle time of the process-data run (ns).
    pub cycle_ns: u64,
    /// What could not be measured on this device, and why.
    pub not_measured: Vec<String>,
}

impl BusReport {
    /// The figure named `name`.
    pub fn get(&self, name: &str) -> Option<&BusCost> {
        self.costs.iter().find(|c| c.name == name)
    }
}

/// Minimum bytes of a read of `n` data bytes.
pub const fn min_read(n: u64) -> u64 {
    ADDRESS_BYTES + READ_WAIT_BYTES + n
}

/// Minimum bytes of a write of `n` data bytes.
pub const fn min_write(n: u64) -> u64 {
    ADDRESS_BYTES + n
}

fn decode(r: &SpiRecord) -> (&'static str, u16, usize) {
    let (Some(&a0), Some(&a1)) = (r.mosi.first(), r.mosi.get(1)) else {
        return ("?", 0, 0);
    };
    let addr = (u16::from(a0) << 5) | u16::from(a1 >> 3);
    match a1 & 0x07 {
        0 => ("nop", addr, 0),
        2 => ("read", addr, r.mosi.len().saturating_sub(2)),
        3 => ("read", addr, r.mosi.len().saturating_sub(3)),
        4 => ("write", addr, r.mosi.len().saturating_sub(2)),
        _ => ("other", addr, r.mosi.len()),
    }
}

/// A board running the firmware's slave application, with a scripted master.
struct Rig {
    board: VirtualBoard,
    counter: u8,
    /// Sum of [`min_mailbox_exchange`] over the exchanges so far.
    mailbox_minimum: u64,
}

impl Rig {
    fn new(target: Target) -> Self {
        let mut board = VirtualBoard::new(BoardConfig::new(target.sii));
        let cpu = (target.make_cpu)(board.io());
        board.set_cpu(cpu);
        board.step(1_000_000); // SII loaded, PDI operational, application started
        Self {
            board,
            counter: 0,
            mailbox_minimum: 0,
        }
    }

    fn ecat_write(&mut self, addr: u16, data: &[u8]) {
        self.board.esc().borrow_mut().ecat_write(addr, data);
    }

    fn ecat_read(&mut self, addr: u16, n: usize) -> Vec<u8> {
        let mut b = vec![0u8; n];
        self.board.esc().borrow_mut().ecat_read(addr, &mut b);
        b
    }

    fn sm(&mut self, n: u16, start: u16, len: u16, control: u8) {
        let s = start.to_le_bytes();
        let l = len.to_le_bytes();
        self.ecat_write(
            0x0800 + 8 * n,
            &[s[0], s[1], l[0], l[1], control, 0, 0x01, 0],
        );
    }

    /// Runs `f` (master actions and board time) `runs` times and returns the SPI cost per run;
    /// the minimum is `minimum_bytes` plus that of the mailbox exchanges `f` made.
    fn measure(
        &mut self,
        name: &str,
        runs: u64,
        minimum_bytes: u64,
        mut f: impl FnMut(&mut Self) -> Result<(), String>,
    ) -> Result<BusCost, String> {
        let before = self.board.esc().borrow().spi_stats.clone();
        let mailbox_before = self.mailbox_minimum;
        {
            let mut esc = self.board.esc().borrow_mut();
            esc.spi_record = true;
            esc.spi_log.clear();
        }
        for _ in 0..runs {
            f(self)?;
        }
        let (after, log) = {
            let mut esc = self.board.esc().borrow_mut();
            esc.spi_record = false;
            (esc.spi_stats.clone(), std::mem::take(&mut esc.spi_log))
        };
        let d = |a: u64, b: u64| (a - b) as f64 / runs as f64;
        let minimum_bytes = minimum_bytes + (self.mailbox_minimum - mailbox_before) / runs.max(1);
        let per_run = log.len() / runs.max(1) as usize;
        if after.errors != before.errors {
            return Err(format!("{name}: the ESC counted SPI protocol errors"));
        }
        Ok(BusCost {
            name: name.into(),
            runs,
            transactions: d(after.transactions, before.transactions),
            bytes: d(after.bytes, before.bytes),
            minimum_bytes,
            split: (
                d(after.address_bytes, before.address_bytes),
                d(after.wait_bytes, before.wait_bytes),
                d(after.read_bytes, before.read_bytes),
                d(after.write_bytes, before.write_bytes),
            ),
            accesses: log[log.len() - per_run..].iter().map(decode).collect(),
            kinds: AccessCounts::of(&log, runs),
        })
    }

    fn al_state(&mut self) -> (u16, u16) {
        let esc = self.board.esc().borrow();
        (
            esc.peek_u16(regs::AL_STATUS),
            esc.peek_u16(regs::AL_STATUS_CODE),
        )
    }

    fn request_state(&mut self, state: u16) -> Result<(), String> {
        self.ecat_write(regs::AL_CONTROL, &state.to_le_bytes());
        self.board.step(100_000);
        match self.al_state() {
            (s, 0) if s == state => Ok(()),
            (s, code) => Err(format!(
                "state {state:#x} requested: AL status {s:#x}, code {code:#06x}"
            )),
        }
    }

    /// One mailbox exchange: the request into SM0, the firmware answers, the master takes
    /// the reply from SM1 and the firmware sees the mailbox free again.
    fn exchange(&mut self, coe: &[u8]) -> Result<Vec<u8>, String> {
        self.counter = self.counter % 7 + 1;
        let mut frame = vec![0u8; MBX_LEN as usize];
        frame[..2].copy_from_slice(&(coe.len() as u16).to_le_bytes());
        frame[5] = 0x03 | self.counter << 4;
        frame[6..6 + coe.len()].copy_from_slice(coe);
        self.ecat_write(MBX_OUT, &frame);
        self.board.step(50_000);
        if self.ecat_read(0x0808 + 5, 1)[0] & 0x08 == 0 {
            return Err("no reply in SM1".into());
        }
        let reply = self.ecat_read(MBX_IN, MBX_LEN as usize);
        self.board.step(50_000);
        let reply_len = 6 + usize::from(u16::from_le_bytes([reply[0], reply[1]]));
        self.mailbox_minimum += min_mailbox_exchange(6 + coe.len(), reply_len);
        Ok(reply)
    }
}

fn sdo(command: u8, index: u16, sub: u8, data: &[u8]) -> Vec<u8> {
    let mut f = vec![0x00, 0x20, command];
    f.extend_from_slice(&index.to_le_bytes());
    f.push(sub);
    f.extend_from_slice(data);
    while f.len() < 10 {
        f.push(0);
    }
    f
}

fn expect_command(reply: &[u8], want: u8, what: &str) -> Result<(), String> {
    match reply.get(8) {
        Some(&c) if c == want => Ok(()),
        other => Err(format!(
            "{what}: SDO reply command {other:02x?}, expected {want:#04x}"
        )),
    }
}

/// Mandatory bytes of one mailbox exchange with a request frame of `request` bytes and a
/// reply frame of `reply` bytes (headers included): each frame from the buffer start, then
/// the buffer's last byte, which frees SM0 / marks SM1 full (ESC-I 8: the ESC opens a
/// buffer on its first byte and closes it on its last), or the whole buffer in one access
/// when that is shorter.
pub const fn min_mailbox_exchange(request: usize, reply: usize) -> u64 {
    let mbx = MBX_LEN as u64;
    let (req, rep) = (request as u64, reply as u64);
    let read = if req + 1 >= mbx {
        min_read(mbx)
    } else {
        min_read(req) + min_read(1)
    };
    let write = if rep + 1 >= mbx {
        min_write(mbx)
    } else {
        min_write(rep) + min_write(1)
    };
    read + write
}

/// Runs the scripted master against `target` (the firmware's application) and counts:
/// INIT -> PREOP, SDO expedited upload and download, a segmented download (complete access
/// of 0x1A00, 7 bytes per segment), PREOP -> SAFEOP (DC SYNC0 at `cycle_ns`), SAFEOP -> OP,
/// and `cycles` process-data cycles in OP.
pub fn measure(target: Target, cycle_ns: u64, cycles: u64) -> Result<BusReport, String> {
    let mut rig = Rig::new(target);
    let mut report = BusReport {
        cycle_ns,
        ..Default::default()
    };
    rig.sm(0, MBX_OUT, MBX_LEN, 0x26);
    rig.sm(1, MBX_IN, MBX_LEN, 0x22);
    // The ESM transition writes AL status code and AL status; it reads AL control and the
    // SyncManagers it checks (2 at I->P).
    let min_init_preop = min_read(2) + 2 * min_read(8) + min_write(2) + min_write(2);
    let c = rig.measure("ESM INIT->PREOP", 1, min_init_preop, |r| r.request_state(2))?;
    report.costs.push(c);

    let c = rig.measure("SDO upload, expedited (0x1018:02)", 1, 0, |r| {
        let reply = r.exchange(&sdo(0x40, 0x1018, 2, &[]))?;
        expect_command(&reply, 0x43, "upload 0x1018:02")
    })?;
    report.costs.push(c);
    let c = rig.measure("SDO download, expedited (0x6443:01)", 1, 0, |r| {
        let reply = r.exchange(&sdo(0x2F, 0x6443, 1, &[1]))?;
        expect_command(&reply, 0x60, "download 0x6443:01")
    })?;
    report.costs.push(c);

    // Segmented: the complete 0x1A00 (as uploaded) downloaded again in 7-byte segments.
    let up = rig.exchange(&sdo(0x50, 0x1A00, 0, &[]))?;
    expect_command(&up, 0x51, "complete-access upload 0x1A00")?;
    let size = u32::from_le_bytes([up[12], up[13], up[14], up[15]]) as usize;
    let value = up[16..16 + size].to_vec();
    let mut exchanges = 0u64;
    let c = rig.measure(
        "SDO download, segmented (0x1A00 complete, 7 B/segment), per exchange",
        1,
        0,
        |r| {
            let reply = r.exchange(&sdo(0x31, 0x1A00, 0, &(size as u32).to_le_bytes()))?;
            expect_command(&reply, 0x70, "initiate segmented download")?;
            exchanges = 1;
            let mut toggle = 0u8;
            for (i, chunk) in value.chunks(7).enumerate() {
                let last = u8::from(i + 1 == value.len().div_ceil(7));
                let unused = (7 - chunk.len() as u8) << 1;
                let mut f = vec![0x00, 0x20, toggle << 4 | unused | last];
                f.extend_from_slice(chunk);
                f.resize(10, 0);
                let reply = r.exchange(&f)?;
                expect_command(&reply, 0x20 | toggle << 4, "download segment")?;
                toggle ^= 1;
                exchanges += 1;
            }
            Ok(())
        },
    )?;
    // Per exchange (initiate + segments).
    let n = exchanges.max(1) as f64;
    let one = c.accesses.len() / exchanges.max(1) as usize;
    report.costs.push(BusCost {
        accesses: c.accesses[c.accesses.len() - one..].to_vec(),
        transactions: c.transactions / n,
        bytes: c.bytes / n,
        minimum_bytes: c.minimum_bytes / exchanges.max(1),
        split: (c.split.0 / n, c.split.1 / n, c.split.2 / n, c.split.3 / n),
        kinds: c.kinds.per(n),
        runs: exchanges,
        ..c
    });

    // Segmented upload: the module description string (longer than the mailbox), when the
    // device has it.
    let probe = rig.exchange(&sdo(0x40, SEGMENTED_UPLOAD_INDEX, 0, &[]))?;
    if probe.get(8) == Some(&0x41) {
        let total = u32::from_le_bytes([probe[12], probe[13], probe[14], probe[15]]) as u64;
        let mut exchanges = 0u64;
        let c = rig.measure(
            "SDO upload, segmented (0x2001 string), per exchange",
            1,
            0,
            |r| {
                let reply = r.exchange(&sdo(0x40, SEGMENTED_UPLOAD_INDEX, 0, &[]))?;
                expect_command(&reply, 0x41, "initiate segmented upload")?;
                exchanges = 1;
                let mut toggle = 0u8;
                loop {
                    let reply =
                        r.exchange(&[0x00, 0x20, 0x60 | toggle << 4, 0, 0, 0, 0, 0, 0, 0])?;
                    let cmd = reply.get(8).copied().unwrap_or(0xFF);
                    if cmd & 0xF0 != toggle << 4 {
                        return Err(format!("upload segment: reply command {cmd:#04x}"));
                    }
                    exchanges += 1;
                    toggle ^= 1;
                    if cmd & 0x01 != 0 {
                        return Ok(());
                    }
                    if exchanges > 64 {
                        return Err("upload segments never ended".into());
                    }
                }
            },
        )?;
        let n = exchanges.max(1) as f64;
        let one = c.accesses.len() / exchanges.max(1) as usize;
        report.costs.push(BusCost {
            name: format!(
                "SDO upload, segmented (0x2001, {total} B in {exchanges} exchanges), per exchange"
            ),
            accesses: c.accesses[c.accesses.len() - one..].to_vec(),
            transactions: c.transactions / n,
            bytes: c.bytes / n,
            minimum_bytes: c.minimum_bytes / exchanges.max(1),
            split: (c.split.0 / n, c.split.1 / n, c.split.2 / n, c.split.3 / n),
            kinds: c.kinds.per(n),
            runs: exchanges,
        });
    } else {
        report.not_measured.push(format!(
            "SDO upload, segmented: the board's device has no object {SEGMENTED_UPLOAD_INDEX:#06x} \
             longer than the mailbox (SDO reply command {:#04x})",
            probe.get(8).copied().unwrap_or(0)
        ));
    }

    let (out_len, in_len) = (4u16, 16u16);
    report.process_data_bytes = (out_len, in_len);
    rig.sm(2, PD_OUT, out_len, 0x64);
    rig.sm(3, PD_IN, in_len, 0x20);
    let t = u64::from_le_bytes(rig.ecat_read(0x0910, 8).try_into().unwrap_or([0; 8]));
    rig.ecat_write(0x09A0, &(cycle_ns as u32).to_le_bytes());
    rig.ecat_write(0x0990, &(t + 200_000).to_le_bytes());
    rig.ecat_write(0x0981, &[0x03]);
    // P->S: AL control, SM2, SM3, 0x0981, 0x09A0, the inputs once, status code + status.
    let min_preop_safeop = min_read(2)
        + 2 * min_read(8)
        + min_read(1)
        + min_read(4)
        + min_write(u64::from(in_len))
        + min_write(2)
        + min_write(2);
    let c = rig.measure("ESM PREOP->SAFEOP (DC SYNC0)", 1, min_preop_safeop, |r| {
        r.request_state(4)
    })?;
    report.costs.push(c);
    let c = rig.measure("ESM SAFEOP->OP", 1, min_read(2) + 2 * min_write(2), |r| {
        r.request_state(8)
    })?;
    report.costs.push(c);

    // Let SYNC0 start, then the cycles: the master writes the outputs and reads the inputs
    // once per cycle (as its LRW does), the board runs one cycle of virtual time.
    rig.board.step(400_000);
    let mut k = 0i16;
    let min_cycle = min_read(u64::from(out_len)) + min_write(u64::from(in_len));
    let c = rig.measure("process-data cycle (DC SYNC0)", cycles, min_cycle, |r| {
        k = k.wrapping_add(97);
        let mut out = k.to_le_bytes().to_vec();
        out.extend_from_slice(&(-k).to_le_bytes());
        r.ecat_write(PD_OUT, &out);
        r.ecat_read(PD_IN, usize::from(in_len));
        r.board.step(cycle_ns);
        match r.al_state() {
            (8, 0) => Ok(()),
            (s, code) => Err(format!(
                "left OP during the cycles: AL status {s:#x}, code {code:#06x}"
            )),
        }
    })?;
    report.costs.push(c);
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;
    use firmware::products::analog_io::sync::MIN_CYCLE_TIME_NS;

    #[test]
    fn minimum_follows_the_spi_protocol() {
        // 2 AO read (2 address + 1 wait + 4) and 8 AI written (2 address + 16).
        assert_eq!(min_read(4) + min_write(16), 25);
        // Expedited SDO: 16-byte frames, then the last byte each way.
        assert_eq!(min_mailbox_exchange(16, 16), (19 + 4) + (18 + 3));
        // Frames that (almost) fill the buffer: one whole-buffer access.
        assert_eq!(min_mailbox_exchange(127, 128), 131 + 130);
    }

    #[test]
    fn firmware_costs_are_counted_and_consistent() {
        let target = crate::tools::sim::firmware_target().unwrap();
        let r = measure(target, u64::from(MIN_CYCLE_TIME_NS), 20).unwrap();
        for c in &r.costs {
            assert!(c.transactions >= 1.0, "{}: no SPI traffic", c.name);
            let (a, w, rd, wr) = c.split;
            assert!((a + w + rd + wr - c.bytes).abs() < 1e-6, "{}", c.name);
            assert!(
                c.bytes >= c.minimum_bytes as f64,
                "{}: below the minimum",
                c.name
            );
            assert!(!c.accesses.is_empty());
            let k = c.kinds;
            assert!(
                (k.nops + k.reads + k.writes - c.transactions).abs() < 1e-6,
                "{}: {k:?}",
                c.name
            );
        }
        let pd = r.get("process-data cycle (DC SYNC0)").unwrap();
        // The outputs are read and the inputs written every cycle.
        assert!(
            pd.accesses.contains(&("read", PD_OUT, 4)),
            "{:?}",
            pd.accesses
        );
        assert!(
            pd.accesses.contains(&("write", PD_IN, 16)),
            "{:?}",
            pd.accesses
        );
        // Reruns count the same bytes.
        let again = measure(
            crate::tools::sim::firmware_target().unwrap(),
            u64::from(MIN_CYCLE_TIME_NS),
            20,
        )
        .unwrap();
        assert_eq!(r, again);
    }

    /// The firmware's device has 0x2001, longer than the mailbox: the segmented upload is
    /// measured; a segment request is read as its frame and SM0's last byte, a segment
    /// written as its frame and SM1's last byte (or the whole buffer when it fills it).
    #[test]
    fn segmented_upload_is_measured() {
        let r = measure(
            crate::tools::sim::firmware_target().unwrap(),
            u64::from(MIN_CYCLE_TIME_NS),
            10,
        )
        .unwrap();
        assert!(r.not_measured.is_empty(), "{:?}", r.not_measured);
        let seg = r
            .costs
            .iter()
            .find(|c| c.name.starts_with("SDO upload, segmented"))
            .unwrap();
        assert!(seg.runs >= 3, "{}: {} exchanges", seg.name, seg.runs);
        assert!(seg.accesses.contains(&("read", MBX_OUT, 16)));
        assert!(seg.accesses.contains(&("read", MBX_OUT + MBX_LEN - 1, 1)));
        let full = seg.accesses.contains(&("write", MBX_IN, MBX_LEN as usize));
        let last = seg.accesses.contains(&("write", MBX_IN + MBX_LEN - 1, 1));
        assert!(full || last, "{:?}", seg.accesses);
    }
}
