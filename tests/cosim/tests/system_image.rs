//! SYSTEM TESTS ON THE IMAGE: ethercrab (a real master, in process) against the virtual
//! board whose MCU is the co-simulator running a product's release ELF (issue 12, section
//! 2), on both boards: the LPC1754 with the ET1100 on SPI (`analog-io`) and the STM32F103
//! with it on the FSMC (`analog-io-stm32`, issue 30). Every test runs once per board (the
//! modules `lpc1754` and `stm32f103`) and also checks that the core did not fault, that no
//! model reported a problem (routing, power, clock rules, an FSMC access that moves no data),
//! and that the chips saw no protocol error.
//!
//! The images are the ones `cargo xtask build` made (`cargo xtask test` builds them first);
//! a missing image fails the tests, it never skips them.

mod common;

use ethercrab::error::{CoeAbortCode, Error, MailboxError};
use ethercrab::{std::ethercat_now, PduStorage, SubDeviceState};
use firmware::platform::board::Mcu;
use firmware::products::analog_io::od::{MODULE_DESCRIPTION, MODULE_DESCRIPTION_INDEX};
use firmware::products::Product;
use futures_lite::future::{block_on, or};
use lpc1754_cosim::bench::{al_status, master, step_to, Board};
use lpc1754_cosim::cosim::Options;
use lpc1754_cosim::machine::ResetCause;
use lpc1754_cosim::run::{image_target, load_image_of, CosimHandle};
use std::cell::RefCell;
use std::rc::Rc;
use virtual_board::models::esc::regs;
use virtual_board::rig::master::tx_rx_task;
use virtual_board::rig::sdo_client::SdoClient;

/// Each test body below once per board, named after its MCU.
macro_rules! on_both_boards {
    ($($test:ident),+ $(,)?) => {
        mod lpc1754 {
            $(#[test]
            fn $test() {
                super::$test(firmware::products::default())
            })+
        }
        mod stm32f103 {
            $(#[test]
            fn $test() {
                super::$test(super::common::stm32_product())
            })+
        }
    };
}

on_both_boards!(
    boot_to_preop_sdo_sdo_info_and_segmented_upload,
    dc_op_and_ten_thousand_cycles_with_dac_and_adc_checked,
    the_advertised_minimum_cycle_holds_under_a_real_masters_traffic,
    sm_watchdog_fault_values,
    mcu_watchdog_resets_a_stuck_firmware,
    eeprom_loaded_never_rising,
);

fn image_board_with(
    product: &Product,
    options: Options,
    sii: impl FnOnce(&mut Vec<u8>),
) -> (Board, CosimHandle) {
    let image = load_image_of(product.name).expect("the product's release image");
    let (mut target, handle) = image_target(image, options).expect("boot ROM checks");
    sii(&mut target.sii);
    let board = Rc::new(RefCell::new(target.into_board(|_| {})));
    (board, handle)
}

fn image_board(product: &Product) -> (Board, CosimHandle) {
    image_board_with(product, Options::default(), |_| {})
}

/// The longest SYNC0 -> LDAC the board's image is held to (ns). The LPC1754's meets the
/// 1 us target (`DcCheck::ldac_met`); the STM32F103's does not (1.2 us mean, 1.6 us max
/// under traffic: the capture interrupt's entry and about 50 instructions to the timer
/// output's forced level, at 72 MHz from flash with two wait states; a one-pulse timer
/// triggered by SYNC0 would drive LDAC without them), and is held to 2 us so a regression
/// still shows.
fn ldac_bound_ns(product: &Product) -> u64 {
    match product.board.mcu() {
        Mcu::Lpc1754 => 1_000,
        Mcu::Stm32f103vc => 2_000,
    }
}

/// No fault, no reported problem, no protocol error on any chip; the ESC used on the board's
/// PDI (SPI on the LPC1754, the FSMC on the STM32F103).
fn assert_clean(product: &Product, board: &Board, handle: &CosimHandle) {
    let facts = handle.with(|c| c.facts()).expect("co-simulator built");
    assert!(facts.fault.is_none(), "{}", facts.summary());
    assert!(facts.reports.is_empty(), "{}", facts.summary());
    let b = board.borrow();
    let spi = b.esc().borrow().spi_stats.clone();
    match product.board.mcu() {
        Mcu::Lpc1754 => assert!(spi.transactions > 0, "the image used the ESC's SPI"),
        Mcu::Stm32f103vc => assert!(
            spi.transactions == 0 && facts.fsmc_cycles > 0,
            "the image used the ESC on the FSMC, not on SPI"
        ),
    }
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
fn boot_to_preop_sdo_sdo_info_and_segmented_upload(product: &Product) {
    let device = product.device;
    let (board, handle) = image_board(product);
    let storage = Box::new(PduStorage::new());
    let (md, tx, rx) = master(&storage).unwrap();
    block_on(or(
        async {
            let group = md
                .init_single_group::<2, 64>(ethercat_now)
                .await
                .expect("init");
            let sd = group.subdevice(&md, 0).unwrap();
            assert_eq!(sd.status().await.unwrap().0, SubDeviceState::PreOp);
            assert_eq!(sd.name(), device.names.order_code);
            // A segmented upload (longer than the 128-byte mailbox), first: the project's
            // client starts at mailbox counter 1, before ethercrab's own exchanges.
            let (mbx_out, mbx_in) = (device.sync_managers[0], device.sync_managers[1]);
            let mut client = SdoClient::<128>::new(mbx_out.start, mbx_in.start, 1);
            let up = client
                .upload(&sd, MODULE_DESCRIPTION_INDEX, 0)
                .await
                .unwrap();
            assert_eq!(std::str::from_utf8(&up.data).unwrap(), MODULE_DESCRIPTION);
            assert!(up.segments >= 2);
            assert_eq!(sd.sdo_read::<u32>(0x1000, 0).await.unwrap(), 0x000C_0191);
            let name: heapless::String<64> = sd.sdo_read(0x1008, 0).await.unwrap();
            assert_eq!(name.as_str(), device.names.device_name);
            assert_eq!(
                sd.sdo_read::<u32>(0x1018, 2).await.unwrap(),
                device.identity.product_code
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
            let want: Vec<u16> = device.od.iter().map(|o| o.index).collect();
            assert_eq!(all.to_vec(), as_ethercrab_reads(&want));
        },
        tx_rx_task(board.clone(), tx, rx),
    ));
    assert_clean(product, &board, &handle);
}

/// INIT -> OP with DC SYNC0 at the advertised minimum cycle, then 10 000 process-data cycles
/// both ways, judged as `cargo xtask bench` judges a cycle time (`lpc1754_cosim::bench::dc_run`): every SYNC0
/// edge loads both DAC channels together with the pair of the frame before it (no missed
/// SYNC0, no stale output), within 1 us of the edge; no AD7689 result is lost; and the AI
/// values follow the ADC model's inputs.
fn dc_op_and_ten_thousand_cycles_with_dac_and_adc_checked(product: &Product) {
    let image = load_image_of(product.name).expect("the product's release image");
    let run = lpc1754_cosim::bench::dc_run(
        &image,
        u64::from(firmware::products::analog_io::sync::MIN_CYCLE_TIME_NS),
        10_000,
        false,
    )
    .unwrap();
    let c = &run.check;
    assert!(
        c.sustained(),
        "{}: {c:?}\n{}",
        c.verdict(),
        run.after.summary()
    );
    assert_eq!(c.edges, 10_000);
    assert_eq!(c.stale_inputs, 0, "AI values off the ADC inputs");
    assert!(
        c.sync0_to_ldac.min_ns > 0 && c.sync0_to_ldac.max_ns <= ldac_bound_ns(product),
        "the image latches after the edge (its capture interrupt), within {} ns: {:?}",
        ldac_bound_ns(product),
        c.sync0_to_ldac
    );
    let facts = &run.after;
    // The ADC ran all along: on the LPC1754 its results read by the CPU from the GPDMA ring
    // (counted by the co-simulator), on the STM32F103 its conversions.
    let adc_results = match product.board.mcu() {
        Mcu::Lpc1754 => facts.samples.read,
        Mcu::Stm32f103vc => facts.traffic.adc_conversions,
    };
    assert!(adc_results > 200_000, "{}", facts.summary());
    if product.board.mcu() == Mcu::Stm32f103vc {
        // The ESC on the FSMC: per judged cycle the PDI task's bus cycles (SM2 event,
        // outputs, inputs).
        let before = run
            .before
            .as_ref()
            .expect("facts at the first judged cycle");
        let per_cycle = (facts.fsmc_cycles - before.fsmc_cycles) as f64 / c.edges as f64;
        assert!(per_cycle >= 10.0, "{per_cycle} FSMC cycles per DC cycle");
    }
    assert!(
        facts.fault.is_none() && facts.reports.is_empty(),
        "{}",
        facts.summary()
    );
}

/// Issue 33: under a real master's traffic (SDO exchanges back to back in OP: segmented
/// upload of the module description, SDO Information, complete access; frame jitter; a
/// moving signal on every ADC channel), 10 000 cycles at the advertised minimum
/// (`MIN_CYCLE_TIME_NS`, judged under this traffic) with no stale output, no late input and
/// no sync error.
fn the_advertised_minimum_cycle_holds_under_a_real_masters_traffic(product: &Product) {
    use lpc1754_cosim::bench::{dc_run_traffic, Program};
    use lpc1754_cosim::traffic::Traffic;
    let image = load_image_of(product.name).expect("the product's release image");
    let min = u64::from(firmware::products::analog_io::sync::MIN_CYCLE_TIME_NS);
    let program = Program::release(&image);
    let run = dc_run_traffic(&program, min, 10_000, false, None, &Traffic::REAL_MASTER).unwrap();
    let c = &run.check;
    eprintln!(
        "{} us, {}: {}; {} cycles: {} stale outputs, {} late inputs, {} missed SYNC0; {} SDO \
         exchanges; SYNC0 -> LDAC mean {:.2} us, max {:.2} us; CPU load {:.1} %",
        min / 1000,
        c.traffic,
        c.verdict(),
        c.edges,
        c.stale_outputs,
        c.late_inputs,
        c.missed_sync0,
        c.sdo_exchanges,
        c.sync0_to_ldac.mean_ns / 1e3,
        c.sync0_to_ldac.max_ns as f64 / 1e3,
        100.0 * c.cpu_load
    );
    assert!(
        c.sustained(),
        "{}: {c:?}\n{}",
        c.verdict(),
        run.after.summary()
    );
    assert_eq!(c.edges, 10_000);
    assert_eq!((c.stale_outputs, c.late_inputs, c.missed_sync0), (0, 0, 0));
    // The slave never left OP (a sync error would have ended the run).
    assert!(c.failure.is_none());
    // The board's LDAC bound (the 1 us target on the LPC1754), under the mailbox traffic too.
    assert!(
        c.sync0_to_ldac.min_ns > 0 && c.sync0_to_ldac.max_ns <= ldac_bound_ns(product),
        "{:?}",
        c.sync0_to_ldac
    );
    // Mailbox traffic all along: a round (4 exchanges) every few cycles at least.
    assert!(c.sdo_exchanges >= 400, "{} SDO exchanges", c.sdo_exchanges);
}

/// SM-synchronous OP, then the master stops: the ESC's process-data watchdog expires, the
/// image sets the outputs to their fault values (0x6443/0x6444) and AL status to SAFE-OP +
/// error with 0x001B.
fn sm_watchdog_fault_values(product: &Product) {
    let (board, handle) = image_board(product);
    let storage = Box::new(PduStorage::new());
    let (md, tx, rx) = master(&storage).unwrap();
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
            assert_eq!(al_status(&board), (0x0008, 0));
            let t = board.borrow().now_ns() + 150_000_000;
            step_to(&board, t);
            assert_eq!(al_status(&board), (0x0014, 0x001B));
            assert_eq!(
                board.borrow().dac().borrow().dac,
                [0x8000, 0x0200],
                "AO1 kept, AO2 -> 0x6444:02"
            );
        },
        tx_rx_task(board.clone(), tx, rx),
    ));
    assert_clean(product, &board, &handle);
}

/// The firmware stops feeding the MCU watchdog (injected: interrupts disabled for ever, a
/// stuck critical section, from 5 ms on): the watchdog resets the chip within its 100 ms,
/// the image boots again (the chip's watchdog reset flag seen: WDTOF on the LPC1754, IWDGRSTF
/// on the STM32F103) and the module is back in INIT.
fn mcu_watchdog_resets_a_stuck_firmware(product: &Product) {
    let (board, handle) = image_board_with(
        product,
        Options {
            lock_up_at_ns: Some(5_000_000),
            ..Default::default()
        },
        |_| {},
    );
    step_to(&board, 4_000_000);
    assert_eq!(al_status(&board), (0x0001, 0), "INIT after the first boot");
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
    assert_eq!(
        al_status(&board),
        (0x0001, 0),
        "back to INIT after the reset"
    );
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
/// (`hw::board::wait_esc_eeprom_loaded`, on each board) lasts its 100 ms on the board's time
/// base: the tick task starts 100 ms later than after a boot whose EEPROM is loaded (the
/// first poll of the pin returns at once there), within 100 us either way: the LPC1754's
/// waiting boot may end up to a 100 us poll late (the STM32F103's polls without a pause),
/// and the loaded boot spends some tens of microseconds starting the application over the
/// PDI (AL status written and read back) before its tick starts.
fn eeprom_loaded_never_rising(product: &Product) {
    let (loaded, loaded_handle) = image_board(product);
    // The LPC1754's bootloader checks the application (about 6 ms) before it starts it.
    step_to(&loaded, 20_000_000);
    let start_without_wait = first_tick_ns(&loaded_handle);

    let (board, handle) = image_board_with(product, Options::default(), |sii| sii[0] ^= 0x40);
    assert!(!board.borrow().esc().borrow().pdi_operational());
    step_to(&board, 600_000_000);
    let first_tick = first_tick_ns(&handle);
    let waited = first_tick - start_without_wait;
    assert!(
        (99_900_000..=100_100_000).contains(&waited),
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
    // Every millisecond from its first run on (when that is depends on the LPC1754
    // bootloader's check of the application, which takes longer for a larger image).
    let due = (600_000_000 - first_tick) / 1_000_000;
    assert!(
        systick + 1 >= due,
        "the tick task ran every ms ({systick} runs, {due} due): {}",
        facts.summary()
    );
    assert_eq!(board.borrow().esc().borrow().spi_stats.errors, 0);
}

/// The OD list as ethercrab 0.7.1 reassembles it: it takes the list type's 2 bytes off every
/// fragment's length, not only the first's (`send_sdo_info_service`), so it loses the last
/// index of each fragment after the first. SOEM gets the whole list (`iface_pysoem`).
fn as_ethercrab_reads(list: &[u16]) -> Vec<u16> {
    // A fragment: the 128-byte mailbox less its header (6), the CoE header (2) and the SDO
    // Information header (4); the first also carries the list type (2).
    let per_fragment = (128 - 6 - 2 - 4) / 2;
    let (first, rest) = list.split_at(list.len().min(per_fragment - 1));
    let mut got = first.to_vec();
    for fragment in rest.chunks(per_fragment) {
        got.extend_from_slice(&fragment[..fragment.len() - 1]);
    }
    got
}
