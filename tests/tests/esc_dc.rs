//! Distributed clocks and SYNC0/SYNC1 generation.

mod common;
use common::*;
use virtual_board::models::esc::{cmd, regs, SyncEdge, SyncSignal};
use virtual_board::rig::board::{BoardConfig, BoardIo, PdiCpu, VirtualBoard};
use virtual_board::rig::sii_builder::minimal_io_device;

#[test]
fn receive_times_latch_on_bwr_0x0900() {
    let mut esc = esc();
    esc.advance(12_345);
    let local = esc.dc_local_time();
    let d = one(&mut esc, cmd::BWR, 0, regs::DC_RECEIVE_TIME_PORT0, &[0; 4]);
    assert_eq!(d.wkc, 1, "WKC counts DC slaves");
    esc.advance(1_000);
    assert_eq!(esc.peek_u32(regs::DC_RECEIVE_TIME_PORT0), local as u32);
    let d = one(&mut esc, cmd::BRD, 0, regs::DC_RECEIVE_TIME_PU, &[0; 8]);
    assert_eq!(u64::from_le_bytes(d.data.try_into().unwrap()), local);
}

#[test]
fn system_time_is_local_time_plus_offset_and_latched() {
    let mut esc = esc();
    esc.advance(1_000);
    esc.ecat_write(regs::DC_SYSTEM_TIME_OFFSET, &1_000_000_000u64.to_le_bytes());
    let expect = esc.dc_local_time() + 1_000_000_000;
    let d = one(&mut esc, cmd::BRD, 0, regs::DC_SYSTEM_TIME, &[0; 8]);
    assert_eq!(u64::from_le_bytes(d.data.try_into().unwrap()), expect);
    esc.ecat_write(regs::DC_SYSTEM_TIME_DELAY, &100u32.to_le_bytes());
    // A 32-bit write compares only the low half.
    let t = esc.dc_system_time();
    esc.ecat_write(
        regs::DC_SYSTEM_TIME,
        &((t as u32).wrapping_sub(100)).to_le_bytes(),
    );
    assert_eq!(
        esc.peek_u32(regs::DC_SYSTEM_TIME_DIFF),
        0,
        "received + delay == local"
    );
    // The PDI reads the system time too (first byte latches).
    esc.advance(10);
    let mut b = [0; 8];
    esc.pdi_read(regs::DC_SYSTEM_TIME, &mut b);
    assert_eq!(u64::from_le_bytes(b), esc.dc_system_time());
}

#[test]
fn drift_control_converges_on_the_reference() {
    let mut esc = esc();
    // The reference clock runs 37 ns ahead of this ESC's system time.
    let reference_base = esc.dc_system_time() - esc.now_ns() + 37;
    for _ in 0..20 {
        esc.advance(1_000);
        let t = esc.now_ns() + reference_base;
        esc.ecat_write(regs::DC_SYSTEM_TIME, &t.to_le_bytes());
    }
    let diff = esc.peek_u32(regs::DC_SYSTEM_TIME_DIFF) & 0x7FFF_FFFF;
    assert!(diff <= 4, "difference {diff} ns after 20 writes");
}

fn start_sync(
    esc: &mut virtual_board::models::esc::Esc,
    start_in: u64,
    cycle: u32,
    act: u8,
) -> u64 {
    let start = esc.dc_system_time() + start_in;
    esc.ecat_write(regs::DC_SYNC0_CYCLE, &cycle.to_le_bytes());
    esc.ecat_write(regs::DC_START_TIME, &start.to_le_bytes());
    esc.ecat_write(regs::DC_ACTIVATION, &[act]);
    start
}

#[test]
fn sync0_edges_at_start_time_and_cycle() {
    let mut esc = esc();
    esc.advance(5_000);
    let t0 = esc.now_ns();
    let start = start_sync(&mut esc, 50_000, 100_000, 0x03);
    assert_eq!(
        esc.peek_u8(regs::DC_ACTIVATION_STATUS) & 1,
        1,
        "first pulse pending"
    );
    let edges = esc.advance(1_000_000);
    assert_eq!(edges.len(), 10);
    for (k, e) in edges.iter().enumerate() {
        assert_eq!(e.signal, SyncSignal::Sync0);
        assert_eq!(e.system_time_ns, start + k as u64 * 100_000);
        assert_eq!(e.time_ns, t0 + 50_000 + k as u64 * 100_000);
    }
    assert_eq!(esc.peek_u8(regs::DC_SYNC0_STATUS), 1);
    assert_eq!(esc.peek_u8(regs::DC_ACTIVATION_STATUS) & 1, 0);
    // 0x0990 reads the next SYNC0 time.
    let mut b = [0; 8];
    esc.ecat_read(regs::DC_START_TIME, &mut b);
    assert_eq!(u64::from_le_bytes(b), start + 1_000_000);
    // Not mapped to 0x0220 by default (0x0151 b3 = 0).
    assert_eq!(esc.al_event_request() & 0x04, 0);
    // Deactivation stops it.
    esc.ecat_write(regs::DC_ACTIVATION, &[0]);
    assert!(esc.advance(1_000_000).is_empty());
}

#[test]
fn sync0_single_shot_sync1_and_past_start() {
    let mut esc = esc();
    start_sync(&mut esc, 10_000, 0, 0x03);
    assert_eq!(esc.advance(1_000_000).len(), 1, "cycle 0 = single shot");
    // SYNC1 20 us after each SYNC0.
    esc.ecat_write(regs::DC_SYNC1_CYCLE, &20_000u32.to_le_bytes());
    start_sync(&mut esc, 10_000, 100_000, 0x07);
    let edges = esc.advance(250_000);
    let kinds: Vec<_> = edges.iter().map(|e| (e.signal, e.system_time_ns)).collect();
    let s0 = edges[0].system_time_ns;
    assert_eq!(
        kinds,
        vec![
            (SyncSignal::Sync0, s0),
            (SyncSignal::Sync1, s0 + 20_000),
            (SyncSignal::Sync0, s0 + 100_000),
            (SyncSignal::Sync1, s0 + 120_000),
            (SyncSignal::Sync0, s0 + 200_000),
            (SyncSignal::Sync1, s0 + 220_000),
        ]
    );
    // A start time in the past never starts (flagged in 0x0984 b2).
    esc.ecat_write(regs::DC_ACTIVATION, &[0]);
    let past = esc.dc_system_time() - 1;
    esc.ecat_write(regs::DC_START_TIME, &past.to_le_bytes());
    esc.ecat_write(regs::DC_ACTIVATION, &[0x03]);
    assert_eq!(esc.peek_u8(regs::DC_ACTIVATION_STATUS) & 0x04, 0x04);
    assert!(esc.advance(10_000_000).is_empty());
}

#[test]
fn sync0_mapped_to_al_event_when_configured() {
    let image = virtual_board::rig::sii_builder::SiiBuilder::new()
        .config_word(1, 0x0E03)
        .build();
    let mut esc =
        virtual_board::models::esc::Esc::new(virtual_board::models::esc::EscConfig::new(image));
    start_sync(&mut esc, 1_000, 10_000, 0x03);
    esc.advance(2_000);
    assert_ne!(esc.al_event_request() & 0x04, 0);
    assert!(esc.irq());
    let mut s = [0];
    esc.pdi_read(regs::DC_SYNC0_STATUS, &mut s);
    assert_eq!(s[0], 1);
    assert_eq!(
        esc.al_event_request() & 0x04,
        0,
        "read of 0x098E acknowledges"
    );
}

struct RecordingCpu(std::rc::Rc<std::cell::RefCell<Vec<(u64, u64)>>>);

impl PdiCpu for RecordingCpu {
    fn on_sync0(&mut self, io: &mut BoardIo, edge: &SyncEdge) {
        self.0.borrow_mut().push((io.now_ns(), edge.time_ns));
    }
}

#[test]
fn board_delivers_sync0_to_the_cpu_at_the_edge_time() {
    let mut board = VirtualBoard::new(BoardConfig::new(minimal_io_device()));
    let seen = std::rc::Rc::new(std::cell::RefCell::new(Vec::new()));
    board.set_cpu(Box::new(RecordingCpu(seen.clone())));
    {
        let mut esc = board.esc().borrow_mut();
        start_sync(&mut esc, 25_000, 50_000, 0x03);
    }
    board.step(1_000_000);
    let seen = seen.borrow();
    assert_eq!(seen.len(), 20);
    for (k, (cpu_now, edge)) in seen.iter().enumerate() {
        assert_eq!(cpu_now, edge, "CPU runs at the edge's virtual time");
        assert_eq!(*edge, 25_000 + k as u64 * 50_000);
    }
    assert_eq!(board.stats.sync0_edges, 20);
}

/// Fault switch: a SYNC0 line that never pulses at the MCU. The ESC's cyclic unit runs on
/// (0x098E status, 0x0990 next time), only no edge comes out of the model.
#[test]
fn fault_sync0_missing_at_the_pin() {
    use virtual_board::models::esc::Sync0Fault;
    let mut esc = esc();
    esc.sync0_fault = Some(Sync0Fault::Missing);
    let start = start_sync(&mut esc, 50_000, 100_000, 0x03);
    assert!(esc.advance(1_000_000).is_empty());
    assert_eq!(esc.peek_u8(regs::DC_SYNC0_STATUS), 1);
    let mut b = [0; 8];
    esc.ecat_read(regs::DC_START_TIME, &mut b);
    assert_eq!(u64::from_le_bytes(b), start + 1_000_000);
}

/// Fault switch: SYNC0 pulses displaced from their nominal times, within the bound, the
/// same sequence for the same seed, in order.
#[test]
fn fault_sync0_jitter_displaces_each_edge_within_its_bound() {
    use virtual_board::models::esc::Sync0Fault;
    let run = |seed| {
        let mut esc = esc();
        esc.sync0_fault = Some(Sync0Fault::Jitter {
            max_ns: 20_000,
            seed,
        });
        let t0 = esc.now_ns();
        start_sync(&mut esc, 50_000, 100_000, 0x03);
        let edges = esc.advance(10_000_000);
        (t0, edges)
    };
    let (t0, edges) = run(7);
    assert_eq!(edges.len(), 100);
    let offsets: Vec<i64> = edges
        .iter()
        .enumerate()
        .map(|(k, e)| e.time_ns as i64 - (t0 + 50_000 + k as u64 * 100_000) as i64)
        .collect();
    assert!(offsets.iter().all(|d| d.abs() <= 20_000), "{offsets:?}");
    assert!(offsets.iter().any(|d| *d < -5_000) && offsets.iter().any(|d| *d > 5_000));
    assert!(edges.windows(2).all(|w| w[0].time_ns < w[1].time_ns));
    assert_eq!(run(7).1, edges);
    assert_ne!(run(8).1, edges);
}

// ---------------------------------------------------------------- SYNC1

/// The SYNC1 edges (system times) among `edges`.
fn sync1_times(edges: &[SyncEdge]) -> Vec<u64> {
    edges
        .iter()
        .filter(|e| e.signal == SyncSignal::Sync1)
        .map(|e| e.system_time_ns)
        .collect()
}

/// The SYNC0 edges (system times) among `edges`.
fn sync0_times(edges: &[SyncEdge]) -> Vec<u64> {
    edges
        .iter()
        .filter(|e| e.signal == SyncSignal::Sync0)
        .map(|e| e.system_time_ns)
        .collect()
}

fn read_u64(esc: &mut virtual_board::models::esc::Esc, addr: u16) -> u64 {
    let mut b = [0; 8];
    esc.ecat_read(addr, &mut b);
    u64::from_le_bytes(b)
}

/// 0x09A4 is the delay of SYNC1 after a SYNC0 pulse, and SYNC1 repeats every
/// (floor(0x09A4 / 0x09A0) + 1) SYNC0 cycles: a delay below the SYNC0 cycle gives a SYNC1
/// after every SYNC0, (n - 1) cycles one every n, a whole multiple plus a shift likewise,
/// n cycles one every n + 1.
#[test]
fn sync1_repeats_every_floor_delay_over_cycle_plus_one_sync0_cycles() {
    const T0: u64 = 100_000;
    let cases: [(u64, u64); 6] = [
        (0, T0),                   // with every SYNC0
        (20_000, T0),              // 20 us after every SYNC0
        (3 * T0, 4 * T0),          // factor 4: D = (n - 1) T0
        (3 * T0 + 50_000, 4 * T0), // plus a shift below T0
        (4 * T0, 5 * T0),          // D = n T0: one more SYNC0 cycle
        (T0 - 1, T0),              // just below one cycle
    ];
    for (d, period) in cases {
        assert_eq!(
            virtual_board::models::esc::sync1_period(T0, d),
            Some(period)
        );
        let mut esc = esc();
        esc.ecat_write(regs::DC_SYNC1_CYCLE, &(d as u32).to_le_bytes());
        let start = start_sync(&mut esc, 10_000, T0 as u32, 0x07);
        assert_eq!(
            read_u64(&mut esc, regs::DC_NEXT_SYNC1),
            start + d,
            "D = {d}: 0x0998 holds the first SYNC1 from the activation on"
        );
        let edges = esc.advance(10_000 + 20 * T0);
        let s1 = sync1_times(&edges);
        assert!(s1.len() >= 3, "D = {d}: {s1:?}");
        for (j, t) in s1.iter().enumerate() {
            assert_eq!(*t, start + d + j as u64 * period, "D = {d}, SYNC1 #{j}");
        }
        // Every SYNC1 lies D after a SYNC0 pulse.
        let s0 = sync0_times(&edges);
        assert!(s1.iter().all(|t| s0.contains(&(t - d))), "D = {d}");
        assert_eq!(
            read_u64(&mut esc, regs::DC_NEXT_SYNC1),
            start + d + s1.len() as u64 * period,
            "D = {d}: 0x0998 is the next SYNC1"
        );
        assert_eq!(esc.peek_u8(regs::DC_SYNC1_STATUS), 1);
    }
}

/// Single-shot SYNC0 (cycle 0): one SYNC1, D after the one SYNC0 pulse.
#[test]
fn sync1_single_shot_follows_the_one_sync0_pulse() {
    let mut esc = esc();
    esc.ecat_write(regs::DC_SYNC1_CYCLE, &250_000u32.to_le_bytes());
    let start = start_sync(&mut esc, 10_000, 0, 0x07);
    let edges = esc.advance(10_000_000);
    assert_eq!(sync0_times(&edges), vec![start]);
    assert_eq!(sync1_times(&edges), vec![start + 250_000]);
}

/// The registers a master writes for oversampling factor `n` at bus cycle `t` (SYNC0 =
/// t / n, SYNC1 = the bus cycle), and the SYNC1 edges that follow.
struct Sync01Setup {
    start: u64,
    cycle0: u32,
    cycle1: u32,
}

fn run_setup(
    esc: &mut virtual_board::models::esc::Esc,
    s: &Sync01Setup,
    span: u64,
) -> Vec<SyncEdge> {
    esc.ecat_write(regs::DC_SYNC0_CYCLE, &s.cycle0.to_le_bytes());
    esc.ecat_write(regs::DC_SYNC1_CYCLE, &s.cycle1.to_le_bytes());
    esc.ecat_write(regs::DC_START_TIME, &s.start.to_le_bytes());
    esc.ecat_write(regs::DC_ACTIVATION, &[0x07]);
    let until = s.start - esc.dc_system_time() + span;
    esc.advance(until)
}

/// SOEM `ecx_dcsync01(ctx, slave, TRUE, T0, T - T0, shift)` (pysoem `dc_sync(True, T0,
/// shift, T - T0)`): 0x0981 = 0, 0x09A0 = T0, 0x09A4 = T - T0, start time aligned to
/// `TrueCyclTime` = ((CyclTime1 / CyclTime0) + 1) * CyclTime0 plus the shift, 100 ms
/// ahead, then 0x0981 = 0x07. SYNC1 comes once per bus cycle T, (n - 1) T0 after the
/// first SYNC0 pulse of each cycle.
#[test]
fn sync1_as_soem_sets_it_for_factor_n() {
    const T: u64 = 1_000_000;
    for n in [2u64, 4, 10, 25] {
        let t0 = T / n;
        let mut esc = esc();
        esc.advance(1_234_567);
        esc.ecat_write(regs::DC_ACTIVATION, &[0]);
        let (cycl0, cycl1, shift) = (t0, T - t0, 20_000u64);
        let true_cycle = (cycl1 / cycl0 + 1) * cycl0;
        assert_eq!(true_cycle, T);
        let t1 = esc.dc_system_time();
        let start = (t1 + 100_000_000) / true_cycle * true_cycle + true_cycle + shift;
        let setup = Sync01Setup {
            start,
            cycle0: cycl0 as u32,
            cycle1: cycl1 as u32,
        };
        let edges = run_setup(&mut esc, &setup, 5 * T - 1);
        let s1 = sync1_times(&edges);
        let expect: Vec<u64> = (0..5).map(|j| start + (n - 1) * t0 + j * T).collect();
        assert_eq!(s1, expect, "n = {n}");
        assert_eq!(sync0_times(&edges).len() as u64, 5 * n, "n = {n}");
    }
}

/// IgH `ecrt_slave_config_dc(sc, 0x0730, T0, shift0, T - T0, 0)`: 0x09A0 = sync0_cycle,
/// 0x09A4 = sync1_cycle + sync1_shift, the start time phased on sync0_cycle + sync1_cycle,
/// then the 16-bit AssignActivate 0x0730 to 0x0980 (0x0980 = 0x30, 0x0981 = 0x07).
#[test]
fn sync1_as_igh_sets_it_for_factor_n() {
    const T: u64 = 500_000;
    let n = 5;
    let t0 = T / n;
    let mut esc = esc();
    esc.advance(777_777);
    let (sync1_cycle, sync1_shift, shift0) = (T - t0, 0u64, 0u64);
    esc.ecat_write(regs::DC_SYNC0_CYCLE, &(t0 as u32).to_le_bytes());
    esc.ecat_write(
        regs::DC_SYNC1_CYCLE,
        &((sync1_cycle + sync1_shift) as u32).to_le_bytes(),
    );
    let phase = t0 + sync1_cycle;
    let start = (esc.dc_system_time() + 10_000_000) / phase * phase + shift0;
    esc.ecat_write(regs::DC_START_TIME, &start.to_le_bytes());
    esc.ecat_write(regs::DC_CYCLIC_UNIT_CONTROL, &0x0730u16.to_le_bytes());
    assert_eq!(esc.peek_u8(regs::DC_ACTIVATION), 0x07);
    let edges = esc.advance(start - esc.dc_system_time() + 4 * T - 1);
    let expect: Vec<u64> = (0..4).map(|j| start + (n - 1) * t0 + j * T).collect();
    assert_eq!(sync1_times(&edges), expect);
}

/// ethercrab: `DcSync::Sync01 { sync1_period }` is written raw to 0x09A4 with the start
/// time rounded down to a whole SYNC0 period. `sync1_period = (n - 1) * T0` gives one SYNC1
/// per bus cycle (what made an EL4732 work, ethercrab issue 368); `n * T0`, as its
/// oversampling example writes, gives one every n + 1 SYNC0 pulses.
#[test]
fn sync1_as_ethercrab_sets_it_right_and_as_its_example_does() {
    const T0: u64 = 50_000;
    let n = 4;
    for (sync1_period, period) in [((n - 1) * T0, n * T0), (n * T0, (n + 1) * T0)] {
        let mut esc = esc();
        esc.advance(3_333_333);
        esc.ecat_write(regs::DC_ACTIVATION, &[0]);
        let start = (esc.dc_system_time() + 100_000) / T0 * T0;
        let setup = Sync01Setup {
            start,
            cycle0: T0 as u32,
            cycle1: sync1_period as u32,
        };
        let edges = run_setup(&mut esc, &setup, 4 * period - 1);
        let expect: Vec<u64> = (0..4).map(|j| start + sync1_period + j * period).collect();
        assert_eq!(sync1_times(&edges), expect, "0x09A4 = {sync1_period}");
    }
}
