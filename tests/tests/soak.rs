//! SOAK TEST (issue 14 section 2): one million process-data cycles (fault_common::CYCLE, in virtual
//! time) of the firmware's slave application on the virtual board, with the faults of the
//! campaign injected at random between stretches of normal operation, seeded and
//! reproducible. After every fault the master recovers the way masters do (acknowledge,
//! back through the states it has to) and the module must be back in OP; a recovery that
//! fails five times is a stuck state.
//!
//! Checked all the way: every value the DAC ever takes is one the master sent in OP, a
//! configured fault value, or the power-on 0 V (the outputs are a code the master's bit
//! flips cannot turn into another valid output); outside OP the DAC holds the fault values;
//! after a recovery it holds them until new outputs arrive; the module's reaction to each
//! fault is the one its row of the campaign asks for (AL state and code).
//!
//! ```text
//! SOAK_CYCLES=1000000 SOAK_SEED=0x5eed0014 cargo test -p virtual-board --test soak -- --nocapture
//! ```

mod fault_common;
use fault_common::*;
use std::collections::BTreeMap;
use virtual_board::models::esc::Sync0Fault;
use virtual_board::models::spi::{SpiFault, SpiTarget};
use virtual_board::rig::scripted::{block, state, AlStatus, ScriptedMaster, Sync};
use virtual_board::rig::sdo_client::{
    expedited_upload, sdo_request_bytes, Emergency, MAILBOX_TYPE_COE,
};

/// Process-data cycles of the default run.
const DEFAULT_CYCLES: u64 = 1_000_000;
/// Seed of the default run.
const DEFAULT_SEED: u64 = 0x5EED_0014;
/// Recoveries tried before a state counts as stuck.
const RECOVERY_ATTEMPTS: usize = 5;
/// The configured fault values (0x6444), not of the outputs' code.
const FAULT_VALUES: [i16; 2] = [0x0123, 0x0456];

/// The outputs of cycle `k` on channel `ch`: both bytes equal (0x0202..=0x7979), so a
/// flipped bit, a dropped byte or bytes from elsewhere never form another valid output.
fn output(k: u64, ch: u64) -> i16 {
    let b = ((k + 7 * ch) % 120 + 2) as i16;
    b << 8 | b
}

fn is_output_code(code: u16) -> bool {
    let v = code >> 1;
    code & 1 == 0 && v >> 8 == v & 0xFF && (2..=121).contains(&(v & 0xFF))
}

fn env(name: &str, default: u64) -> u64 {
    match std::env::var(name) {
        Ok(s) => {
            let s = s.trim();
            let parsed = match s.strip_prefix("0x") {
                Some(hex) => u64::from_str_radix(hex, 16),
                None => s.parse(),
            };
            parsed.unwrap_or_else(|_| panic!("{name}={s}: not a number"))
        }
        Err(_) => default,
    }
}

struct Soak {
    m: ScriptedMaster,
    rng: Rng,
    seed: u64,
    start_ns: u64,
    k: u64,
    sync: Sync,
    faults: BTreeMap<&'static str, u64>,
    checked_loads: usize,
    dac_loads: u64,
    stuck: u64,
    recoveries: u64,
    last_fault: &'static str,
}

impl Soak {
    fn new(seed: u64) -> Self {
        let m = ScriptedMaster::firmware(|c| c.capture = false);
        m.wait(2_000_000);
        m.init().expect("bring-up");
        let sync = Sync::Dc {
            cycle_ns: CYCLE as u32,
        };
        m.to_op(sync, |m| {
            fault_config(m, FAULT_VALUES.map(|v| Some(i32::from(v))))
        })
        .expect("OP");
        let start_ns = m.now_ns();
        let s = Self {
            m,
            rng: Rng::new(seed),
            seed,
            start_ns,
            k: 0,
            sync,
            faults: BTreeMap::new(),
            checked_loads: 0,
            dac_loads: 0,
            stuck: 0,
            recoveries: 0,
            last_fault: "none",
        };
        s.m.start_cyclic(&s.outputs());
        s
    }

    fn outputs(&self) -> [u8; 4] {
        ScriptedMaster::ao_image(output(self.k, 0), output(self.k, 1))
    }

    fn fault_codes(&self) -> [u16; 2] {
        FAULT_VALUES.map(dac_code)
    }

    /// Process-data cycles so far: the virtual time since OP in cycles.
    fn cycles(&self) -> u64 {
        (self.m.now_ns() - self.start_ns) / CYCLE
    }

    fn context(&self) -> String {
        format!(
            "after {:?}, AL status {:?}, seed {:#x}, cycle {} (rerun: SOAK_SEED={:#x} SOAK_CYCLES={} cargo test -p \
             virtual-board --test soak -- --nocapture)",
            self.last_fault,
            self.m.al_status().map(|s| s.pair()),
            self.seed,
            self.cycles(),
            self.seed,
            self.cycles() + 1
        )
    }

    /// Every DAC load since the last check is an output the master sent, a fault value,
    /// or the power-on 0 V; the loads are then forgotten (memory stays flat).
    fn check_dac(&mut self) {
        let faults = self.fault_codes();
        let loads = {
            let b = self.m.board().borrow();
            let mut dac = b.dac().borrow_mut();
            std::mem::take(&mut dac.updates)
        };
        for u in &loads {
            let ok = is_output_code(u.code)
                || u.code == faults[usize::from(u.channel)]
                || (u.code == 0 && self.dac_loads < 2);
            assert!(
                ok,
                "DAC channel {} took {:#06x}: neither an output nor the fault value; {}",
                u.channel,
                u.code,
                self.context()
            );
            self.dac_loads += 1;
        }
        self.checked_loads += loads.len();
        self.m.board().borrow_mut().sync_edges.clear();
    }

    fn al(&self) -> AlStatus {
        self.m
            .al_status()
            .unwrap_or_else(|e| panic!("{e}; {}", self.context()))
    }

    /// `n` cycles of normal operation: new outputs every cycle, which reach the DAC.
    fn run(&mut self, n: u64) {
        for _ in 0..n {
            self.k += 1;
            self.m.set_outputs(&self.outputs());
            self.m.wait_cycle_slot();
            let r = self.m.cycle(&self.outputs());
            assert!(r.is_ok(), "cycle: {r:?}; {}", self.context());
        }
        self.m.wait(CYCLE);
        let want = [dac_code(output(self.k, 0)), dac_code(output(self.k, 1))];
        assert_eq!(self.m.dac(), want, "outputs follow; {}", self.context());
        self.check_dac();
    }

    /// `n` cycles while a fault is on: new outputs, the master's errors ignored.
    fn run_through(&mut self, n: u64) {
        for _ in 0..n {
            self.k += 1;
            self.m.set_outputs(&self.outputs());
            self.m.wait_cycle_slot();
            let _ = self.m.cycle(&self.outputs());
        }
    }

    fn count(&mut self, kind: &'static str) {
        self.last_fault = kind;
        *self.faults.entry(kind).or_insert(0) += 1;
    }

    fn dc(&self) -> bool {
        matches!(self.sync, Sync::Dc { .. })
    }

    /// The module left OP with `code` (any of them); its outputs hold the fault values.
    fn expect_fault(&mut self, codes: &[u16], what: &str) {
        let s = self.al();
        assert!(
            s.state != state::OP && s.error && codes.contains(&s.code),
            "{what}: AL status {:?}, expected one of {codes:#06x?}; {}",
            s.pair(),
            self.context()
        );
        assert_eq!(
            self.m.dac(),
            self.fault_codes(),
            "{what}: fault values; {}",
            self.context()
        );
        self.check_dac();
    }

    fn expect_op(&mut self, what: &str) {
        let s = self.al();
        assert_eq!(s.pair(), (state::OP, 0), "{what}; {}", self.context());
    }

    /// Back to OP as a master does it; until new outputs arrive the DAC holds the fault
    /// values if the module had left OP.
    fn recover(&mut self) {
        self.recoveries += 1;
        for _ in 0..RECOVERY_ATTEMPTS {
            if self.try_recover() {
                return;
            }
        }
        self.stuck += 1;
        panic!("stuck: no way back to OP; {}", self.context());
    }

    fn try_recover(&mut self) -> bool {
        let m = &self.m;
        m.plug_cable();
        {
            let b = m.board().borrow();
            let mut esc = b.esc().borrow_mut();
            esc.sync0_fault = None;
            esc.spi_faults.clear();
        }
        // Drop what the mailbox holds (Emergencies of the fault, a stale answer).
        let _ = m.drain_mailbox(8);
        m.take_emergencies();
        m.take_unexpected();
        let Ok(s) = m.al_status() else { return false };
        // Still in OP (an error flag to acknowledge at most): the process data go on.
        if s.state == state::OP {
            m.start_cyclic(&self.outputs());
            return m
                .request_state(state::OP)
                .is_ok_and(|s| s.pair() == (state::OP, 0));
        }
        // Out of OP: no outputs until the check that the fault values hold.
        m.stop_cyclic();
        if m.request_state(s.state).is_err() {
            return false;
        }
        // Through INIT when the state is not usable as it is.
        let Ok(mut now) = m.al_status() else {
            return false;
        };
        if now.error || now.state == state::BOOT {
            let _ = m.request_state(state::INIT);
            now = match m.al_status() {
                Ok(s) => s,
                Err(_) => return false,
            };
        }
        if now.state == state::INIT {
            if m.configure_mailbox().is_err() || m.expect_state(state::PREOP).is_err() {
                return false;
            }
            now.state = state::PREOP;
        }
        // From PREOP a new process-data start, in DC or SM-sync; SAFEOP keeps its sync.
        if now.state == state::PREOP {
            self.sync = if self.rng.chance(70) {
                Sync::Dc {
                    cycle_ns: CYCLE as u32,
                }
            } else {
                Sync::SmSync { cycle_ns: CYCLE }
            };
            if m.rewrite_process_data(self.sync).is_err() || m.expect_state(state::SAFEOP).is_err()
            {
                return false;
            }
        }
        if m.expect_state(state::OP).is_err() {
            return false;
        }
        m.wait(3 * CYCLE);
        assert_eq!(
            m.dac(),
            self.fault_codes(),
            "fault values until new outputs in OP; {}",
            self.context()
        );
        self.k += 1;
        m.start_cyclic(&self.outputs());
        true
    }

    // ------------------------------------------------------------------ faults

    fn lose_frames(&mut self) {
        let n = self.rng.range(1, 4) as u32;
        self.count(if n == 1 {
            "frame lost"
        } else {
            "frames lost in a row"
        });
        self.m.lose_frames(n);
        self.run_through(u64::from(n));
        self.m.wait(2 * CYCLE);
        if self.dc() && n >= 2 {
            self.expect_fault(&[al::SYNC_ERROR], "frames lost in DC");
            self.recover();
        } else {
            self.expect_op("frames lost");
        }
    }

    fn lose_replies(&mut self) {
        self.count("answers lost");
        let n = self.rng.range(1, 3);
        self.m.lose_replies(n as u32);
        self.run_through(n);
        self.run(5);
        self.expect_op("answers lost");
    }

    fn duplicate(&mut self) {
        self.count("frames repeated");
        let n = self.rng.range(1, 3);
        self.m.duplicate_frames(n as u32);
        self.run_through(n);
        self.run(5);
        self.expect_op("frames repeated");
    }

    fn master_stops(&mut self) {
        let t = self.rng.range(1, 150) * 1_000_000;
        self.count("master stops");
        self.m.stop_cyclic();
        self.m.wait(t);
        if self.dc() {
            self.expect_fault(&[al::SYNC_ERROR], "master stops in DC");
        } else if t > 101_000_000 {
            self.expect_fault(&[al::SM_WATCHDOG], "master stops in SM-sync");
        } else if t < 99_000_000 {
            self.expect_op("master pauses in SM-sync");
        }
        self.recover();
    }

    fn cable(&mut self) {
        // Mostly short, sometimes beyond the SDO server's 1 s transfer timeout.
        let mut t_ms = if self.rng.chance(80) {
            self.rng.range(1, 300)
        } else {
            self.rng.range(1100, 2000)
        };
        // A pull that ends just before the SM watchdog (100 ms) races with it: it expires
        // during the recovery's first exchanges, after the check that the module is back.
        if (90..100).contains(&t_ms) {
            t_ms += 10;
        }
        let t = t_ms * 1_000_000;
        self.count("cable pulled");
        // Sometimes in the middle of a segmented upload.
        let transfer = self.rng.chance(50);
        if transfer {
            let r = block(self.m.sdo().exchange(
                &self.m,
                &virtual_board::rig::sdo_client::request::initiate_upload(0x2001, 0, false),
                &mut |_| {},
            ));
            assert!(r.is_ok(), "initiate upload: {r:?}; {}", self.context());
        }
        self.m.pull_cable();
        self.m.wait(t);
        self.m.plug_cable();
        self.m.stop_cyclic();
        let s = self.al();
        if s.state != state::OP || s.error {
            self.expect_fault(&[al::SYNC_ERROR, al::SM_WATCHDOG], "cable pulled");
        }
        self.recover();
        if transfer {
            // The next request works (the transfer timed out or a new one replaces it).
            self.sdo_upload();
        }
    }

    fn sync0_missing(&mut self) {
        if !self.dc() {
            return self.lose_replies();
        }
        self.count("SYNC0 missing");
        self.set_sync0_fault(Some(Sync0Fault::Missing));
        self.m.wait(3_000_000);
        self.m.stop_cyclic();
        self.expect_fault(&[al::FATAL_SYNC_ERROR], "SYNC0 missing");
        self.recover();
    }

    fn sync0_jitter(&mut self) {
        if !self.dc() {
            return self.duplicate();
        }
        self.count("SYNC0 jitter");
        let seed = self.rng.next();
        self.set_sync0_fault(Some(Sync0Fault::Jitter {
            max_ns: 20_000,
            seed,
        }));
        let n = self.rng.range(50, 500);
        self.run(n);
        self.set_sync0_fault(None);
        self.expect_op("SYNC0 jitter");
    }

    fn set_sync0_fault(&self, f: Option<Sync0Fault>) {
        self.m.board().borrow().esc().borrow_mut().sync0_fault = f;
    }

    fn spi(&mut self, target: SpiTarget, fault: SpiFault) {
        let b = self.m.board().borrow();
        b.esc().borrow_mut().spi_faults.inject(target, fault);
    }

    /// A bit flipped or SPI_SEL dropped while the firmware reads the outputs.
    fn spi_outputs(&mut self) {
        self.count("PDI fault on the outputs");
        let sm2 = self.m.sm(2).unwrap().start;
        let fault = match self.rng.below(3) {
            0 => SpiFault::FlipMiso {
                byte: self.rng.range(3, 6) as usize,
                bit: self.rng.below(8) as u8,
            },
            1 => SpiFault::FlipMosi {
                byte: self.rng.range(0, 6) as usize,
                bit: self.rng.below(8) as u8,
            },
            _ => SpiFault::DropSel {
                byte: self.rng.range(2, 6) as usize,
            },
        };
        self.spi(SpiTarget::Read(sm2), fault);
        self.run(5);
        self.expect_op("PDI fault on the outputs");
    }

    /// A bit flipped or SPI_SEL dropped in the data of whatever the firmware does next.
    fn spi_any(&mut self) {
        self.count("PDI fault, any access");
        let fault = match self.rng.below(3) {
            0 => SpiFault::FlipMiso {
                byte: self.rng.range(3, 12) as usize,
                bit: self.rng.below(8) as u8,
            },
            1 => SpiFault::FlipMosi {
                byte: self.rng.range(0, 12) as usize,
                bit: self.rng.below(8) as u8,
            },
            _ => SpiFault::DropSel {
                byte: self.rng.range(2, 12) as usize,
            },
        };
        self.spi(SpiTarget::Next, fault);
        // Whatever it hit: no wrong output, and the way back to OP works.
        self.m.wait(5 * CYCLE);
        self.check_dac();
        let s = self.al();
        if s.state != state::OP || s.error {
            self.recover();
        }
        self.run(5);
    }

    /// An SDO upload between the cyclic frames; the value is right.
    fn sdo_upload(&mut self) {
        self.count("SDO exchange");
        let id = firmware::products::analog_io::identity::IDENTITY;
        let (index, sub, want) = match self.rng.below(3) {
            0 => (
                0x1000,
                0,
                firmware::products::analog_io::od::DEVICE_TYPE
                    .to_le_bytes()
                    .to_vec(),
            ),
            1 => (0x1018, 2, id.product_code.to_le_bytes().to_vec()),
            _ => (0x6444, 1, i32::from(FAULT_VALUES[0]).to_le_bytes().to_vec()),
        };
        let r = self.m.sdo_upload(index, sub);
        assert_eq!(
            r.as_ref().ok(),
            Some(&want),
            "{index:#06x}:{sub}: {r:?}; {}",
            self.context()
        );
        self.m.take_emergencies();
    }

    /// Repeat requests after an answer: each returns the identical answer.
    fn repeat_storm(&mut self) {
        self.count("repeat requests");
        // Emergencies still queued go first (the slave sends one each time SM1 is free).
        self.m.drain_mailbox(16).unwrap();
        self.m.take_emergencies();
        let p = sdo_request_bytes(&[0x40, 0x00, 0x10, 0, 0, 0, 0, 0]);
        assert!(self.m.send_mailbox(&p).unwrap());
        // The answer (an Emergency from the last recovery may come first).
        let mut first = block(self.m.sdo().mailbox().read(&self.m)).unwrap();
        while Emergency::parse(&first).is_some() {
            first = block(self.m.sdo().mailbox().read(&self.m)).unwrap();
        }
        assert_eq!(expedited_upload(&first).unwrap().0, 0x1000);
        // The repeats return the last frame the slave wrote: the answer, or an Emergency
        // it sent after the answer was read; all of them the same.
        let last = block(self.m.sdo().mailbox().repeat(&self.m)).unwrap();
        assert!(
            last == first || Emergency::parse(&last).is_some(),
            "repeat: {:02x?}; {}",
            &last[..16],
            self.context()
        );
        for _ in 0..self.rng.range(1, 20) {
            let again = block(self.m.sdo().mailbox().repeat(&self.m)).unwrap();
            assert_eq!(again, last, "repeat; {}", self.context());
        }
    }

    /// A burst of requests against a full mailbox, replies read late: one reply each.
    fn flood(&mut self) {
        self.count("mailbox flood");
        let mut accepted = 0;
        for _ in 0..self.rng.range(2, 8) {
            let p = sdo_request_bytes(&[0x40, 0x18, 0x10, 1, 0, 0, 0, 0]);
            if block(self.m.sdo().mailbox().send(&self.m, MAILBOX_TYPE_COE, &p)).unwrap() {
                accepted += 1;
            }
        }
        let mut replies = 0;
        for _ in 0..400 {
            match block(self.m.sdo().mailbox().try_read(&self.m)).unwrap() {
                Some(f) if Emergency::parse(&f).is_some() => {}
                Some(f) => {
                    assert_eq!(expedited_upload(&f).unwrap().0, 0x1018);
                    replies += 1;
                }
                None if replies == accepted => break,
                None => self.m.wait(20_000),
            }
        }
        assert_eq!(
            replies,
            accepted,
            "one reply per request; {}",
            self.context()
        );
    }

    /// AL control requests in random order, then back to OP.
    fn state_cycling(&mut self) {
        self.count("state changes");
        for _ in 0..self.rng.range(1, 6) {
            let target =
                [state::INIT, state::PREOP, state::SAFEOP, 0x05][self.rng.below(4) as usize];
            let before = self.al().state;
            if before == state::INIT && target == state::PREOP {
                self.m.configure_mailbox().unwrap();
            }
            if before == state::PREOP && target == state::SAFEOP {
                self.m.rewrite_process_data(self.sync).unwrap();
            }
            let s = self.m.request_state(target).unwrap();
            if target == 0x05 {
                assert_eq!(
                    s.pair(),
                    (err(before), al::UNKNOWN_STATE),
                    "{}",
                    self.context()
                );
            } else if before == state::INIT && target == state::SAFEOP {
                assert_eq!(
                    s.pair(),
                    (err(before), al::INVALID_STATE_CHANGE),
                    "{}",
                    self.context()
                );
            }
            if s.error {
                self.m.request_state(s.state).unwrap();
            }
            if self.al().state != state::OP {
                assert_eq!(
                    self.m.dac(),
                    self.fault_codes(),
                    "outside OP; {}",
                    self.context()
                );
            }
        }
        self.recover();
    }

    /// A wrong SM2 length at PREOP -> SAFEOP: 0x001D; then the right one.
    fn wrong_sm(&mut self) {
        self.count("wrong SM configuration");
        self.m.stop_cyclic();
        self.m.request_state(state::PREOP).unwrap();
        let sm2 = self.m.sm(2).unwrap();
        self.m.rewrite_process_data(self.sync).unwrap();
        self.m.write_sm(2, sm2.registers(3, 1)).unwrap();
        let s = self.m.request_state(state::SAFEOP).unwrap();
        assert_eq!(
            s.pair(),
            (err(state::PREOP), al::INVALID_OUTPUT_CONFIG),
            "{}",
            self.context()
        );
        assert_eq!(self.m.dac(), self.fault_codes());
        self.recover();
    }

    /// A mapping entry that cannot be mapped: aborted, the mapping kept.
    fn wrong_pdo(&mut self) {
        self.count("wrong PDO mapping");
        self.m.stop_cyclic();
        self.m.request_state(state::PREOP).unwrap();
        let before = self.m.sdo_upload(0x1600, 1).unwrap();
        self.m.sdo_download(0x1600, 0, &[0]).unwrap();
        let r = self
            .m
            .sdo_download(0x1600, 1, &0x6401_0110u32.to_le_bytes());
        assert_eq!(
            r.unwrap_err().abort_code(),
            Some(0x0604_0041),
            "{}",
            self.context()
        );
        self.m.sdo_download(0x1600, 0, &[2]).unwrap();
        assert_eq!(self.m.sdo_upload(0x1600, 1).unwrap(), before);
        self.recover();
    }

    /// An illegal AL control value: refused with its code, acknowledged, back to OP.
    fn illegal_al_control(&mut self) {
        self.count("illegal AL control");
        let now = self.al().state;
        let (control, code) = match self.rng.below(3) {
            0 => (
                [0x05u16, 0x06, 0x07, 0x09, 0x0F][self.rng.below(5) as usize],
                al::UNKNOWN_STATE,
            ),
            1 => (u16::from(state::BOOT), al::INVALID_STATE_CHANGE),
            _ => (u16::from(now | state::ERROR), 0),
        };
        let s = self.m.write_al_control(control).unwrap();
        if code == 0 {
            assert_eq!(
                s.pair(),
                (now, 0),
                "acknowledge without an error; {}",
                self.context()
            );
        } else {
            assert_eq!(
                s.pair(),
                (err(now), code),
                "AL control {control:#06x}; {}",
                self.context()
            );
            assert_eq!(
                self.m.dac(),
                [dac_code(output(self.k, 0)), dac_code(output(self.k, 1))]
            );
        }
        self.recover();
    }

    fn one_fault(&mut self) {
        match self.rng.below(18) {
            0 | 1 => self.lose_frames(),
            2 => self.lose_replies(),
            3 => self.duplicate(),
            4 => self.master_stops(),
            5 => self.cable(),
            6 => self.sync0_missing(),
            7 => self.sync0_jitter(),
            8 | 9 => self.spi_outputs(),
            10 => self.spi_any(),
            11 => self.sdo_upload(),
            12 => self.repeat_storm(),
            13 => self.flood(),
            14 => self.state_cycling(),
            15 => self.wrong_sm(),
            16 => self.illegal_al_control(),
            _ => self.wrong_pdo(),
        }
        self.check_dac();
    }
}

#[test]
fn soak_one_million_cycles_with_random_faults() {
    let cycles = env("SOAK_CYCLES", DEFAULT_CYCLES);
    let seed = env("SOAK_SEED", DEFAULT_SEED);
    println!(
        "soak: {cycles} cycles of {} us, seed {seed:#x} (rerun: SOAK_SEED={seed:#x} \
         SOAK_CYCLES={cycles} cargo test -p virtual-board --test soak -- --nocapture)",
        CYCLE / 1000
    );
    let wall = std::time::Instant::now();
    let mut s = Soak::new(seed);
    while s.cycles() < cycles {
        let n = s.rng.range(10, 1500).min(cycles - s.cycles()).max(1);
        s.run(n);
        if s.cycles() < cycles {
            s.one_fault();
        }
    }
    s.m.stop_cyclic();
    s.check_dac();
    let end = s.al();
    let total: u64 = s.faults.values().sum();
    println!("cycles: {}", s.cycles());
    println!("faults injected: {total}");
    for (kind, n) in &s.faults {
        println!("  {kind:<28} {n:>7}");
    }
    println!(
        "recoveries to OP: {}, stuck states: {}, DAC loads checked: {}",
        s.recoveries, s.stuck, s.dac_loads
    );
    let net = s.m.net_stats();
    println!(
        "frames: {} ({} lost to the slave, {} answers lost, {} repeated, {} while unplugged)",
        net.frames, net.lost_to_slave, net.lost_from_slave, net.duplicated, net.unplugged
    );
    println!(
        "final state: AL status {:#04x}, code {:#06x}; wall time {:.1} s",
        end.pair().0,
        end.code,
        wall.elapsed().as_secs_f64()
    );
    assert_eq!(
        end.pair(),
        (state::OP, 0),
        "the master reaches OP at the end"
    );
    assert_eq!(s.stuck, 0);
    assert!(s.cycles() >= cycles);
}
