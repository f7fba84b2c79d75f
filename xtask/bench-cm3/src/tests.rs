//! The scenarios do what the benchmark claims they measure.

use super::*;
use firmware::io::analog::sampler::SampleRing;
use firmware::stacks::ethercat::sync::SyncMode;

fn rig() -> Rig {
    let mut r = Rig::new(firmware::products::analog_io::sync::MIN_CYCLE_TIME_NS).unwrap();
    assert_eq!(r.app.sync().mode(), SyncMode::DcSync0);
    for _ in 0..4 {
        r.cycle().unwrap();
    }
    r
}

#[test]
fn dc_cycle_stages_preloads_latches_and_writes_inputs() {
    let mut r = rig();
    r.master_outputs();
    let writes = r.esc.writes;
    let out = r.irq().unwrap();
    assert!(!out.apply_outputs, "DC mode: outputs wait for SYNC0");
    let pair = r.preload().expect("fresh outputs are preloaded");
    assert!(matches!(r.sync0(), DacAction::PulseLdac(p) if p == pair));
    r.poll().unwrap();
    assert!(
        r.esc.writes > writes,
        "inputs written to SM3 after the edge"
    );
    r.check_op().unwrap();
    // Nothing fresh: the next edge keeps the outputs.
    assert_eq!(r.sync0(), DacAction::Keep);
}

#[test]
fn sdo_upload_and_download_are_answered() {
    let mut r = rig();
    r.master_sdo(0x40, 0x1018, 2, [0; 4]).unwrap();
    r.irq().unwrap();
    assert_eq!(
        r.master_sdo_reply().unwrap(),
        (0x43, 0x1754u32.to_le_bytes())
    );
    r.master_sdo(0x2F, 0x6443, 1, [1, 0, 0, 0]).unwrap();
    r.irq().unwrap();
    assert_eq!(r.master_sdo_reply().unwrap().0, 0x60);
    r.check_op().unwrap();
}

#[test]
fn sampler_paths_move_samples() {
    let mut ring = SampleRing::<RING>::new();
    let (mut p, mut c) = ring.split();
    let mut s = Sampler::new(PublishMode::Latest);
    assert!(push_one(&mut p, 3));
    assert_eq!(drain(&mut c, &mut s), 1);
    queue_scan(&mut p).unwrap();
    assert_eq!(drain(&mut c, &mut s), 8);
    assert_eq!(s.received(), 9);
}

#[test]
fn dma_path_drains_whole_scans_across_the_ring_end() {
    let mut d = DmaRig::new();
    let mut s = Sampler::new(PublishMode::Latest);
    assert_eq!(d.drain(&mut s), Ok(0));
    for k in 0..3 * RING_WORDS as u32 / 8 + 5 {
        d.dma_writes_scan();
        assert_eq!(d.words_written(), Ok((k + 1) * 8));
        assert_eq!(d.drain(&mut s), Ok(1), "scan {k}");
        s.publish();
        assert_eq!(s.code(5), Some((0x5000 + k) as u16));
    }
    let before = d.halves.get();
    d.halves.on_terminal_count();
    assert_eq!(d.halves.get(), before + 1);
}

#[test]
fn driver_port_runs_the_et1100_spi_driver() {
    let mut port = driver_port();
    let mut word = [0xAAu8; 4];
    assert_eq!(port.read(0x0440, &mut word), Ok(et1100::AlEvents::empty()));
    assert_eq!(word, [0; 4]);
    assert_eq!(port.write(0x1180, &[1; 16]), Ok(et1100::AlEvents::empty()));
}
