//! SYSTEM TESTS ON THE IMAGE: ethercrab (a real master, in process) against the virtual
//! board whose MCU is the LPC1754 co-simulator running the release ELF (issue 12, section
//! 2). Every test also checks that the core did not fault and that no model reported a
//! problem (routing, power, clock rules), and that the chips saw no protocol error.
//!
//! The image is the one `cargo xtask build` made (`cargo xtask test` builds it first and
//! passes it in `LPC1754_IMAGE`); a missing image fails the tests, it never skips them.

use ethercrab::error::{CoeAbortCode, Error, MailboxError};
use ethercrab::subdevice_group::DcConfiguration;
use ethercrab::{
    std::ethercat_now, DcSync, MainDevice, MainDeviceConfig, PduStorage, SubDeviceState,
};
use firmware::product::device::DEVICE;
use firmware::product::identity::{IDENTITY, NAMES};
use firmware::product::od::{MODULE_DESCRIPTION, MODULE_DESCRIPTION_INDEX};
use futures_lite::future::{block_on, or};
use lpc1754_cosim::cosim::Options;
use lpc1754_cosim::machine::ResetCause;
use lpc1754_cosim::run::{image_target, load_image, CosimHandle};
use std::cell::RefCell;
use std::rc::Rc;
use std::time::Duration;
use virtual_board::models::adc::Signal;
use virtual_board::models::esc::regs;
use virtual_board::rig::board::{BoardConfig, VirtualBoard};
use virtual_board::rig::master::{in_process_timeouts, tx_rx_task};
use virtual_board::rig::sdo_client::SdoClient;

type Board = Rc<RefCell<VirtualBoard>>;

fn image_board_with(options: Options, sii: impl FnOnce(&mut Vec<u8>)) -> (Board, CosimHandle) {
    let image = load_image().expect("the release image");
    let (mut target, handle) = image_target(image, options).expect("boot ROM checks");
    sii(&mut target.sii);
    let board = Rc::new(RefCell::new(VirtualBoard::new(BoardConfig::new(
        target.sii,
    ))));
    let cpu = (target.make_cpu)(board.borrow().io());
    board.borrow_mut().set_cpu(cpu);
    (board, handle)
}

fn image_board() -> (Board, CosimHandle) {
    image_board_with(Options::default(), |_| {})
}

fn master(
    storage: &PduStorage<16, { PduStorage::element_size(1100) }>,
) -> (MainDevice<'_>, ethercrab::PduTx<'_>, ethercrab::PduRx<'_>) {
    let (tx, rx, pdu_loop) = storage.try_split().expect("split once");
    let md = MainDevice::new(
        pdu_loop,
        in_process_timeouts(),
        MainDeviceConfig {
            dc_static_sync_iterations: 50,
            ..Default::default()
        },
    );
    (md, tx, rx)
}

fn step_to(board: &Board, t: u64) {
    let mut b = board.borrow_mut();
    let now = b.now_ns();
    if t > now {
        b.step(t - now);
    }
}

fn al(board: &Board) -> (u16, u16) {
    let b = board.borrow();
    let esc = b.esc().borrow();
    (
        esc.peek_u16(regs::AL_STATUS),
        esc.peek_u16(regs::AL_STATUS_CODE),
    )
}

/// No fault, no reported problem, no protocol error on any chip.
fn assert_clean(board: &Board, handle: &CosimHandle) {
    let facts = handle.with(|c| c.facts()).expect("co-simulator built");
    assert!(facts.fault.is_none(), "{}", facts.summary());
    assert!(facts.reports.is_empty(), "{}", facts.summary());
    let b = board.borrow();
    let spi = b.esc().borrow().spi_stats.clone();
    assert!(spi.transactions > 0, "the image used the ESC's SPI");
    assert_eq!(spi.errors, 0, "ET1100 SPI protocol errors");
    let dac = b.dac().borrow();
    assert_eq!(
        (
            dac.aborted_frames,
            dac.long_frames,
            dac.reserved_commands,
            dac.bad_addresses
        ),
        (0, 0, 0, 0),
        "AD5663 frames"
    );
    let adc = b.adc().borrow();
    assert!(adc.frames > 0, "the image used the ADC");
    assert_eq!(
        adc.cycle_violations, 0,
        "AD7689 conversions closer than tCYC"
    );
}

fn aborted(r: Result<(), Error>) -> Option<CoeAbortCode> {
    match r {
        Err(Error::Mailbox(MailboxError::Aborted { code, .. })) => Some(code),
        _ => None,
    }
}

/// From reset to PRE-OP: the image boots (clocks, pins, buses), starts the application once
/// EEPROM_LOADED is high, and the master's INIT -> PRE-OP sees the mailbox; then SDO uploads
/// and downloads (accepted and refused), SDO Information, and a segmented upload.
#[test]
fn boot_to_preop_sdo_sdo_info_and_segmented_upload() {
    let (board, handle) = image_board();
    let storage = Box::new(PduStorage::new());
    let (md, tx, rx) = master(&storage);
    block_on(or(
        async {
            let group = md
                .init_single_group::<2, 64>(ethercat_now)
                .await
                .expect("init");
            let sd = group.subdevice(&md, 0).unwrap();
            assert_eq!(sd.status().await.unwrap().0, SubDeviceState::PreOp);
            assert_eq!(sd.name(), NAMES.order_code);
            // A segmented upload (longer than the 128-byte mailbox), first: the project's
            // client starts at mailbox counter 1, before ethercrab's own exchanges.
            let (mbx_out, mbx_in) = (DEVICE.sync_managers[0], DEVICE.sync_managers[1]);
            let mut client = SdoClient::<128>::new(mbx_out.start, mbx_in.start, 1);
            let up = client
                .upload(&sd, MODULE_DESCRIPTION_INDEX, 0)
                .await
                .unwrap();
            assert_eq!(std::str::from_utf8(&up.data).unwrap(), MODULE_DESCRIPTION);
            assert!(up.segments >= 2);
            assert_eq!(sd.sdo_read::<u32>(0x1000, 0).await.unwrap(), 0x000C_0191);
            let name: heapless::String<64> = sd.sdo_read(0x1008, 0).await.unwrap();
            assert_eq!(name.as_str(), NAMES.device_name);
            assert_eq!(
                sd.sdo_read::<u32>(0x1018, 2).await.unwrap(),
                IDENTITY.product_code
            );
            sd.sdo_write(0x6444, 1, 0x2000i32).await.unwrap();
            assert_eq!(sd.sdo_read::<i32>(0x6444, 1).await.unwrap(), 0x2000);
            assert_eq!(
                aborted(sd.sdo_write(0x1000, 0, 5u32).await),
                Some(CoeAbortCode::ReadOnlyWrite)
            );
            assert_eq!(
                aborted(sd.sdo_write(0x5555, 0, 5u32).await),
                Some(CoeAbortCode::NotFound)
            );
            // SDO Information: the object list as the host-compiled application serves it.
            let all = sd
                .sdo_info_object_description_list(ethercrab::ObjectDescriptionListQuery::All)
                .await
                .unwrap()
                .expect("SDO Information");
            let want: Vec<u16> = firmware::product::od::OD.iter().map(|o| o.index).collect();
            assert_eq!(all.to_vec(), want);
        },
        tx_rx_task(board.clone(), tx, rx),
    ));
    assert_clean(&board, &handle);
}

/// INIT -> OP with DC SYNC0, then 10 000 process-data cycles both ways: every output pair
/// the master sends reaches both DAC channels together at the SYNC0 edge after its frame
/// (none missed, none stale), and the AI values follow the ADC model's inputs. Then the
/// master stops in SM-synchronous terms: see `sm_watchdog_fault_values`.
#[test]
fn dc_op_and_ten_thousand_cycles_with_dac_and_adc_checked() {
    const CYCLE: u64 = 100_000;
    const CYCLES: u64 = 10_000;
    let (board, handle) = image_board();
    let storage = Box::new(PduStorage::new());
    let (md, tx, rx) = master(&storage);
    block_on(or(
        async {
            let mut group = md
                .init_single_group::<2, 64>(ethercat_now)
                .await
                .expect("init");
            for mut sd in group.iter_mut(&md) {
                sd.set_dc_sync(DcSync::Sync0);
            }
            let group = group.into_pre_op_pdi(&md).await.expect("PDI");
            let group = group
                .configure_dc_sync(
                    &md,
                    DcConfiguration {
                        start_delay: Duration::from_millis(1),
                        sync0_period: Duration::from_nanos(CYCLE),
                        sync0_shift: Duration::from_nanos(CYCLE / 2),
                    },
                )
                .await
                .expect("DC");
            let group = group.into_safe_op(&md).await.expect("SAFE-OP");
            let group = group.into_op(&md).await.expect("OP");
            {
                let adc = board.borrow().adc().clone();
                let mut adc = adc.borrow_mut();
                adc.inputs[0] = Signal::Constant(1.0);
                adc.inputs[5] = Signal::Constant(7.5);
                adc.inputs[7] = Signal::Constant(9.0);
            }
            let mut sent = Vec::new();
            let mut ai_bad = 0;
            for i in 0..CYCLES {
                // Both in the 0..10 V range (INTEGER16 0..=0x7FFF), different every cycle.
                let a = ((i * 3) % 0x7FFF) as i16;
                let b = (0x7FFF - (i * 7) % 0x7FFF) as i16;
                {
                    let sd = group.subdevice(&md, 0).unwrap();
                    let mut o = sd.outputs_raw_mut();
                    o[0..2].copy_from_slice(&a.to_le_bytes());
                    o[2..4].copy_from_slice(&b.to_le_bytes());
                }
                let t0 = board.borrow().now_ns();
                let resp = group.tx_rx_dc(&md).await.expect("cycle");
                assert!(resp.all_op(), "left OP at cycle {i}");
                sent.push((t0, a, b));
                if i > 20 {
                    let sd = group.subdevice(&md, 0).unwrap();
                    let img = sd.inputs_raw();
                    let ai = |ch: usize| i16::from_le_bytes([img[2 * ch], img[2 * ch + 1]]);
                    for (ch, volts) in [(0, 1.0), (5, 7.5), (7, 9.0)] {
                        let want = volts / 10.0 * 32768.0;
                        if (f64::from(ai(ch)) - want).abs() > 1.0 {
                            ai_bad += 1;
                        }
                    }
                }
                step_to(&board, t0 + resp.extra.next_cycle_wait.as_nanos() as u64);
            }
            assert_eq!(ai_bad, 0, "AI values off the ADC inputs");
            let facts = handle.with(|c| c.facts()).unwrap();
            assert!(
                facts.samples.lost == 0 && facts.ssp1_overruns == 0,
                "AD7689 results lost: {}",
                facts.summary()
            );
            assert!(facts.samples.read > 200_000, "{}", facts.summary());
            // Every pair loaded at the first SYNC0 edge after its frame, both channels at
            // once (AO << 1: 0..0x7FFF spans the DAC's 0..10 V).
            let b = board.borrow();
            let updates = b.dac().borrow().updates.clone();
            let edges: Vec<u64> = b.sync_edges.iter().map(|e| e.time_ns).collect();
            // On the image the LDAC edge follows SYNC0 by the capture interrupt's latency
            // (the host-compiled harness latches at the edge itself): within 2 us here.
            let mut missing = 0;
            let mut latency_max = 0;
            // From the first SYNC0 edge on (the frames before it are overwritten before any
            // edge latches them), up to the last edge.
            let first_edge = edges[0];
            for &(t0, a, bb) in sent
                .iter()
                .filter(|s| s.0 > first_edge)
                .take(sent.len() - 40)
            {
                let edge = edges.iter().copied().find(|&e| e > t0).unwrap();
                let code = |v: i16| (v as u16) << 1;
                let at: Vec<_> = updates
                    .iter()
                    .filter(|u| u.time_ns >= edge && u.time_ns <= edge + 2_000)
                    .collect();
                let a_at = at.iter().find(|u| u.channel == 0 && u.code == code(a));
                let b_at = at.iter().find(|u| u.channel == 1 && u.code == code(bb));
                match (a_at, b_at) {
                    (Some(x), Some(y)) if x.time_ns == y.time_ns => {
                        latency_max = latency_max.max(x.time_ns - edge);
                    }
                    _ => {
                        if missing < 3 {
                            eprintln!(
                                "pair {a:#06x}/{bb:#06x} sent at {t0} ns, edge {edge} ns: {:?}",
                                updates
                                    .iter()
                                    .filter(|u| u.time_ns + 200_000 >= edge
                                        && u.time_ns <= edge + 200_000)
                                    .collect::<Vec<_>>()
                            );
                        }
                        missing += 1
                    }
                }
            }
            assert_eq!(
                missing, 0,
                "output pairs not latched together after their SYNC0 edge"
            );
            assert!(
                latency_max > 0,
                "the image latches after the edge, not at it"
            );
        },
        tx_rx_task(board.clone(), tx, rx),
    ));
    assert_clean(&board, &handle);
}

/// SM-synchronous OP, then the master stops: the ESC's process-data watchdog expires, the
/// image sets the outputs to their fault values (0x6443/0x6444) and AL status to SAFE-OP +
/// error with 0x001B.
#[test]
fn sm_watchdog_fault_values() {
    let (board, handle) = image_board();
    let storage = Box::new(PduStorage::new());
    let (md, tx, rx) = master(&storage);
    block_on(or(
        async {
            let group = md
                .init_single_group::<2, 64>(ethercat_now)
                .await
                .expect("init");
            {
                let sd = group.subdevice(&md, 0).unwrap();
                sd.sdo_write(0x6443, 1, 0u8).await.unwrap();
                sd.sdo_write(0x6443, 2, 1u8).await.unwrap();
                sd.sdo_write(0x6444, 2, 0x0100i32).await.unwrap();
            }
            let group = group.into_op(&md).await.expect("OP");
            for _ in 0..10 {
                {
                    let sd = group.subdevice(&md, 0).unwrap();
                    let mut o = sd.outputs_raw_mut();
                    o[0..2].copy_from_slice(&0x4000i16.to_le_bytes());
                    o[2..4].copy_from_slice(&0x7000i16.to_le_bytes());
                }
                group.tx_rx(&md).await.unwrap();
                let t = board.borrow().now_ns() + 1_000_000;
                step_to(&board, t);
            }
            assert_eq!(board.borrow().dac().borrow().dac, [0x8000, 0xE000]);
            assert_eq!(al(&board), (0x0008, 0));
            let t = board.borrow().now_ns() + 150_000_000;
            step_to(&board, t);
            assert_eq!(al(&board), (0x0014, 0x001B));
            assert_eq!(
                board.borrow().dac().borrow().dac,
                [0x8000, 0x0200],
                "AO1 kept, AO2 -> 0x6444:02"
            );
        },
        tx_rx_task(board.clone(), tx, rx),
    ));
    assert_clean(&board, &handle);
}

/// The firmware stops feeding the MCU watchdog (injected: interrupts disabled for ever, a
/// stuck critical section, from 5 ms on): the watchdog resets the chip within its 100 ms,
/// the image boots again (WDTOF seen) and the module is back in INIT.
#[test]
fn mcu_watchdog_resets_a_stuck_firmware() {
    let (board, handle) = image_board_with(
        Options {
            lock_up_at_ns: Some(5_000_000),
            ..Default::default()
        },
        |_| {},
    );
    step_to(&board, 4_000_000);
    assert_eq!(al(&board), (0x0001, 0), "INIT after the first boot");
    // Make the ESC's AL status differ from INIT, as a master would have moved it.
    board
        .borrow()
        .esc()
        .borrow_mut()
        .poke(regs::AL_STATUS, &0x0002u16.to_le_bytes());
    step_to(&board, 200_000_000);
    let facts = handle.with(|c| c.facts()).unwrap();
    assert_eq!(
        facts.resets.iter().map(|r| r.0).collect::<Vec<_>>(),
        [ResetCause::Watchdog],
        "{}",
        facts.summary()
    );
    let (cause, at) = facts.resets[0];
    assert_eq!(cause, ResetCause::Watchdog);
    assert!(
        (100_000_000..=120_000_000).contains(&at),
        "reset {at} ns: 100 ms after the last feed before 5 ms"
    );
    assert_eq!(al(&board), (0x0001, 0), "back to INIT after the reset");
    assert!(
        facts.fault.is_none() && facts.reports.is_empty(),
        "{}",
        facts.summary()
    );
}

/// When SysTick (the tick task, started at the end of `init`) first ran.
fn first_tick_ns(handle: &CosimHandle) -> u64 {
    let facts = handle.with(|c| c.facts()).unwrap();
    facts
        .exceptions
        .iter()
        .find(|e| e.1 == "SysTick")
        .and_then(|e| e.2.first_entry_ns)
        .unwrap_or_else(|| panic!("the tick task never ran: {}", facts.summary()))
}

/// The ESC never loads its EEPROM (a corrupt SII configuration area: EEPROM_LOADED stays
/// low, the PDI stays off): the image waits as designed, its tasks keep running, and it
/// neither faults nor touches the dead PDI with protocol errors. The wait in `init`
/// (`hw::board::wait_esc_eeprom_loaded`) lasts its 100 ms on the Timer1 time base: the tick
/// task starts 100 ms later than after a boot whose EEPROM is loaded (the first poll of the
/// pin returns at once there), within one 100 us poll, less the few microseconds the loaded
/// boot spends starting the application over SPI after the wait.
#[test]
fn eeprom_loaded_never_rising() {
    let (loaded, loaded_handle) = image_board();
    step_to(&loaded, 5_000_000);
    let start_without_wait = first_tick_ns(&loaded_handle);

    let (board, handle) = image_board_with(Options::default(), |sii| sii[0] ^= 0x40);
    assert!(!board.borrow().esc().borrow().pdi_operational());
    step_to(&board, 600_000_000);
    let waited = first_tick_ns(&handle) - start_without_wait;
    assert!(
        (99_990_000..=100_100_000).contains(&waited),
        "the EEPROM_LOADED wait took {waited} ns, not 100 ms"
    );
    let facts = handle.with(|c| c.facts()).unwrap();
    assert!(facts.fault.is_none(), "{}", facts.summary());
    assert!(facts.reports.is_empty(), "{}", facts.summary());
    assert!(
        facts.resets.is_empty(),
        "the watchdog stayed fed: {}",
        facts.summary()
    );
    let systick = facts
        .exceptions
        .iter()
        .find(|e| e.1 == "SysTick")
        .map_or(0, |e| e.2.count);
    assert!(
        systick >= 490,
        "the tick task ran every ms: {}",
        facts.summary()
    );
    assert_eq!(board.borrow().esc().borrow().spi_stats.errors, 0);
}
