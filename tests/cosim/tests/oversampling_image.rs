//! INPUT OVERSAMPLING ON THE IMAGE (docs/book/oversampling.md): ethercrab assigns the block
//! PDOs over SDO in PRE-OP (0x1A10 status, 0x1A11 time, the sample PDOs) and runs DC SYNC0
//! for 10 s of virtual time; every AD7689 conversion reaches it exactly once (the scan
//! counter continuous, no block flagged) at 250 kSPS, and a sine fed to AI1 is rebuilt
//! from the samples and their DC times with under 0.1 % amplitude error. Refusals: a set of
//! PDOs that does not hold the cycle's scans, and an order the rule does not allow.

use ethercrab::error::{CoeAbortCode, Error, MailboxError};
use ethercrab::{std::ethercat_now, PduStorage};
use futures_lite::future::{block_on, or};
use lpc1754_cosim::bench::{master, Storage};
use lpc1754_cosim::oversampling::{ai1_samples, check_stream, fit_sine, run, Config};
use lpc1754_cosim::run::load_image;
use std::cell::RefCell;
use std::rc::Rc;
use virtual_board::rig::master::tx_rx_task;

/// 10 s at 1 ms with all eight sample PDOs: every conversion, the sine rebuilt.
#[test]
fn ten_seconds_at_1_ms_every_conversion_once_and_the_sine_rebuilt() {
    let image = load_image().expect("the release image");
    let config = Config {
        cycle_ns: 1_000_000,
        cycles: 10_000,
        sample_pdos: 8,
        sine_hz: 1_234.5,
        update_pdos: 0,
    };
    let r = run(&image, config).unwrap();
    let c = check_stream(&r);
    eprintln!("{c:?}, {} input bytes per cycle", r.input_bytes);
    assert_eq!(r.blocks.len(), 10_000);
    assert_eq!((c.lost, c.duplicated, c.flagged_blocks), (0, 0, 0), "{c:?}");
    assert_eq!(c.scans_range, (31, 32), "{c:?}");
    // 10 s of 250 kSPS, within one scan.
    let want = 250_000.0 * r.span_ns as f64 * 1e-9;
    assert!((c.samples as f64 - want).abs() <= 8.0, "{c:?}, want {want}");
    assert!(
        c.time_jitter_ns == 0,
        "block times off the uniform grid: {c:?}"
    );
    let fit = fit_sine(&ai1_samples(&r), config.sine_hz);
    eprintln!("{fit:?}");
    assert!(fit.amplitude_error < 0.001, "{fit:?}");
    // The DC times of the samples are the times the ADC model converted them.
    assert!(fit.time_error_ns.abs() < 1_000.0, "{fit:?}");
    // 0x1C33:06 covers the time from each SYNC0 edge to the cycle's block in SM3, and is
    // not a guess far above it (the SM3 write's cost per byte is measured here).
    let longest = r.sync0_to_inputs_ns.iter().copied().max().unwrap_or(0);
    let mean = r.sync0_to_inputs_ns.iter().sum::<u64>() as f64 / r.sync0_to_inputs_ns.len() as f64;
    eprintln!(
        "0x1C33:06 {} ns; SYNC0 -> inputs in SM3: mean {mean:.0} ns, max {longest} ns over {} edges",
        r.input_calc_copy_ns,
        r.sync0_to_inputs_ns.len()
    );
    assert!(r.sync0_to_inputs_ns.len() >= 9_990);
    assert!(
        u64::from(r.input_calc_copy_ns) >= longest
            && u64::from(r.input_calc_copy_ns) <= longest + longest / 4,
        "0x1C33:06 {} ns against {longest} ns measured",
        r.input_calc_copy_ns
    );
    let after = &r.after;
    assert!(after.reports.is_empty(), "{}", after.summary());
}

fn aborted(r: Result<(), Error>) -> Option<CoeAbortCode> {
    match r {
        Err(Error::Mailbox(MailboxError::Aborted { code, .. })) => Some(code),
        _ => None,
    }
}

/// 0x1C13 refuses an order the block PDOs do not allow (0x06040043) and a PDO that does not
/// exist (0x06090030), over SDO on the image.
#[test]
fn bad_block_assignments_are_refused_over_sdo() {
    let image = load_image().expect("the release image");
    let (target, _handle) =
        lpc1754_cosim::run::image_target(image, Default::default()).expect("boot ROM checks");
    let board = Rc::new(RefCell::new(target.into_board(|_| {})));
    let storage: Box<Storage> = Box::new(PduStorage::new());
    let (md, tx, rx) = master(&storage).unwrap();
    block_on(or(
        async {
            let group = md
                .init_single_group::<2, 64>(ethercat_now)
                .await
                .expect("init");
            let sd = group.subdevice(&md, 0).unwrap();
            sd.sdo_write(0x1C13, 0, 0u8).await.unwrap();
            sd.sdo_write(0x1C13, 1, 0x1A10u16).await.unwrap();
            sd.sdo_write(0x1C13, 2, 0x1A21u16).await.unwrap();
            assert_eq!(
                aborted(sd.sdo_write(0x1C13, 0, 2u8).await),
                Some(CoeAbortCode::Incompatible)
            );
            assert_eq!(
                aborted(sd.sdo_write(0x1C13, 2, 0x1A28u16).await),
                Some(CoeAbortCode::ValueOutOfRange)
            );
            sd.sdo_write(0x1C13, 2, 0x1A20u16).await.unwrap();
            sd.sdo_write(0x1C13, 0, 2u8).await.unwrap();
            assert_eq!(sd.sdo_read::<u16>(0x1C13, 2).await.unwrap(), 0x1A20);
            assert_eq!(sd.sdo_read::<u16>(0x8000, 3).await.unwrap(), 32);
            assert_eq!(sd.sdo_read::<u32>(0x1A20, 32).await.unwrap(), 0x6020_2010);
        },
        tx_rx_task(board.clone(), tx, rx),
    ));
}
