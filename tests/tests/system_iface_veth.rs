//! SYSTEM TEST: the virtual board on a Linux network interface ([`virtual_board::tools::iface`])
//! with ethercrab's own raw-socket networking on the other end of a veth pair.
//!
//! - [`ethercrab_drives_the_firmware_over_a_veth_pair`]: the firmware's slave application (the
//!   host-compiled firmware on the board, as `cargo xtask sim --iface vb1` serves it) on its
//!   generated SII, with every analog input held at its own voltage: ethercrab reads the
//!   identity (SII and SDO), walks it to OP and exchanges process data; every input value it
//!   read is that voltage truncated to a 0x6401 step, and every output pair it wrote reached the
//!   DAC model, in order, but for any the board's CPU skipped while it ran far behind the wall
//!   clock ([`virtual_board::tools::analog_check`]).
//! - [`ethercrab_gets_its_words_echoed_over_a_veth_pair`]: the transport alone, with the echo
//!   responder (`cargo xtask sim --iface vb1 --echo`, no CoE): every word that comes back is one
//!   the master sent before, never an older one after a newer, and the last comes back exactly.
//!
//! Needs root (network namespaces, raw sockets), `ip` (iproute2) and tshark, so it is
//! ignored by default; `cargo xtask test` runs it explicitly (CI runs as root and the setup
//! installs tshark), and it fails, naming what is missing, when it cannot run. Everything
//! happens in a private network namespace created for the test
//! (`unshare(CLONE_NEWNET)` on the test's own thread), so the veth pair never shows up
//! on the host and disappears with the namespace when the test ends. The commands are
//! the ones the book gives for a manual run (docs/book/getting-started-virtual.md):
//!
//! ```text
//! ip link add vb0 type veth peer name vb1
//! ip link set vb0 up && ip link set vb1 up
//! cargo xtask sim --iface vb1        # the board
//! <master> vb0                       # ethercrab, SOEM's slaveinfo, ...
//! ```

use ethercrab::std::{ethercat_now, tx_rx_task};
use ethercrab::{MainDevice, MainDeviceConfig, PduStorage, Timeouts};
use firmware::products::analog_io::identity::{IDENTITY, NAMES};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;
use virtual_board::models::adc::Signal;
use virtual_board::models::dac::DacUpdate;
use virtual_board::rig::board::{BoardConfig, VirtualBoard};
use virtual_board::rig::sii_builder::minimal_io_device;
use virtual_board::tools::analog_check::{
    check_inputs, check_outputs_on_the_wall_clock, OutputsTaken, AI_LEVELS_V,
};
use virtual_board::tools::iface::{
    ip, serve, veth_missing, veth_pair_in_new_namespace, RawSocket, ServeOptions, ServeStats,
};
use virtual_board::tools::sim::responder::EchoResponder;
use virtual_board::tools::sim::{firmware_target, tshark};

/// What the board's side of a run gives back.
struct BoardSide {
    stats: ServeStats,
    pcap: Vec<u8>,
    dac_updates: Vec<DacUpdate>,
}

/// Serves the board `make_board` builds (in the board's own thread) on vb1 of a veth pair in a
/// new network namespace of the calling thread, and runs `master` with ethercrab on vb0
/// against it. Bounded in wall time (the board serves 60 s at most).
fn on_a_veth_pair<T>(
    make_board: impl FnOnce() -> Result<VirtualBoard, String> + Send + 'static,
    master: impl AsyncFnOnce(&MainDevice<'_>) -> Result<T, String>,
) -> Result<(T, BoardSide), String> {
    veth_pair_in_new_namespace("vb0", "vb1")?;

    let stop = Arc::new(AtomicBool::new(false));
    let board_stop = stop.clone();
    let (ready_tx, ready_rx) = std::sync::mpsc::channel();
    let board_thread = std::thread::spawn(move || {
        let sock = RawSocket::open("vb1").map_err(|e| e.to_string())?;
        let mut board = make_board()?;
        ready_tx.send(()).ok();
        let opts = ServeOptions {
            // Bounded even if the master never finishes.
            duration: Some(Duration::from_secs(60)),
            ..Default::default()
        };
        let stats = serve(&mut board, &sock, &board_stop, &opts, &mut |s| {
            eprintln!("board: {} frames, AL status {:#06x}", s.frames, s.al_status)
        })
        .map_err(|e| e.to_string())?;
        let pcap = board
            .pcap()
            .ok_or("the board captured nothing")?
            .bytes()
            .to_vec();
        let dac_updates = board.dac().borrow().updates.clone();
        Ok::<_, String>(BoardSide {
            stats,
            pcap,
            dac_updates,
        })
    });
    ready_rx
        .recv_timeout(Duration::from_secs(10))
        .map_err(|_| "the board thread did not start".to_string())?;

    let storage: Box<PduStorage<16, { PduStorage::element_size(1100) }>> =
        Box::new(PduStorage::new());
    let (tx, rx, pdu_loop) = storage.try_split().expect("split once");
    let md = MainDevice::new(
        pdu_loop,
        // ethercrab's default timeouts (30 ms per PDU, 10 ms per EEPROM read): the board
        // answers every frame at its arrival, as an ET1100 does.
        Timeouts {
            wait_loop_delay: Duration::from_millis(1),
            state_transition: Duration::from_secs(5),
            ..Default::default()
        },
        MainDeviceConfig {
            dc_static_sync_iterations: 100,
            ..Default::default()
        },
    );
    let net = tx_rx_task("vb0", tx, rx).map_err(|e| format!("ethercrab on vb0: {e}"))?;
    let result = futures_lite::future::block_on(futures_lite::future::or(master(&md), async {
        match net.await {
            Ok(_) => Err("ethercrab's network task ended".to_string()),
            Err(e) => Err(format!("ethercrab's network task failed: {e}")),
        }
    }));
    stop.store(true, Ordering::Relaxed);
    let board = board_thread
        .join()
        .map_err(|_| "the board thread panicked".to_string())??;
    // Tidy up explicitly too (the namespace takes the pair with it anyway).
    let _ = ip("link del vb0");
    Ok((result?, board))
}

/// Saves the capture and decodes it with tshark: every frame EtherCAT, none malformed.
fn assert_capture_clean(pcap: &[u8], name: &str) {
    let path = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    std::fs::write(&path, pcap).unwrap();
    tshark::assert_clean(&path);
}

/// Output pairs the master sends in OP, each for [`EXCHANGES_PER_PAIR`] exchanges.
const PAIRS: u16 = 100;
/// Exchanges that carry the same output pair, [`EXCHANGE_GAP`] apart: the pair stays in SM2
/// for 10 ms, longer than the host-compiled firmware's CPU usually lags behind the wall clock
/// (1.3 ms at most here), so the firmware sees every pair.
const EXCHANGES_PER_PAIR: u16 = 5;
/// Wall time between two exchanges.
const EXCHANGE_GAP: Duration = Duration::from_millis(2);
/// Working counter of the group's LRW with one slave that reads and writes.
const LRW_WKC: u16 = 3;

/// What ethercrab saw of the firmware.
struct FirmwareRun {
    sii_name: String,
    sii_product: u32,
    sdo_product: u32,
    sdo_name: String,
    taken: Vec<OutputsTaken>,
    inputs: Vec<[i16; 8]>,
    exchanges: usize,
}

/// ethercrab's walk of the firmware: identity, OP, [`PAIRS`] output pairs, PRE-OP.
async fn drive_the_firmware(md: &MainDevice<'_>) -> Result<FirmwareRun, String> {
    let group = md
        .init_single_group::<2, 64>(ethercat_now)
        .await
        .map_err(|e| format!("init: {e}"))?;
    let (sii_name, sii_product, sdo_product, sdo_name) = {
        let sd = group.subdevice(md, 0).map_err(|e| e.to_string())?;
        let product = sd
            .sdo_read::<u32>(0x1018, 2)
            .await
            .map_err(|e| format!("SDO 0x1018:02: {e}"))?;
        let name: heapless::String<64> = sd
            .sdo_read(0x1008, 0)
            .await
            .map_err(|e| format!("SDO 0x1008: {e}"))?;
        (
            sd.name().to_string(),
            sd.identity().product_id,
            product,
            name.to_string(),
        )
    };
    let group = group.into_op(md).await.map_err(|e| format!("OP: {e}"))?;
    let mut taken: Vec<OutputsTaken> = Vec::new();
    let mut inputs = Vec::new();
    let mut exchanges = 0;
    for n in 1..=PAIRS {
        // A new pair each time, none repeated (97 and 89 are prime to 0x7FFF).
        let values = [
            ((u32::from(n) * 97) % 0x7FFF) as i16,
            (0x7FFF - (u32::from(n) * 89) % 0x7FFF) as i16,
        ];
        for _ in 0..EXCHANGES_PER_PAIR {
            {
                let sd = group.subdevice(md, 0).map_err(|e| e.to_string())?;
                let mut o = sd.outputs_raw_mut();
                o[..2].copy_from_slice(&values[0].to_le_bytes());
                o[2..4].copy_from_slice(&values[1].to_le_bytes());
            }
            let resp = group.tx_rx(md).await.map_err(|e| format!("tx_rx: {e}"))?;
            exchanges += 1;
            if resp.working_counter == LRW_WKC {
                if taken.last().map(|t| t.values) != Some(values) {
                    taken.push(OutputsTaken {
                        values,
                        may_be_replaced: false,
                    });
                }
                let sd = group.subdevice(md, 0).map_err(|e| e.to_string())?;
                let raw = sd.inputs_raw();
                inputs.push(std::array::from_fn(|ch| {
                    i16::from_le_bytes([raw[2 * ch], raw[2 * ch + 1]])
                }));
            }
            // No frame is in flight: blocking ethercrab's network task now holds
            // nothing up.
            std::thread::sleep(EXCHANGE_GAP);
        }
    }
    let group = group
        .into_safe_op(md)
        .await
        .map_err(|e| format!("SAFE-OP: {e}"))?;
    group
        .into_pre_op(md)
        .await
        .map_err(|e| format!("PRE-OP: {e}"))?;
    Ok(FirmwareRun {
        sii_name,
        sii_product,
        sdo_product,
        sdo_name,
        taken,
        inputs,
        exchanges,
    })
}

#[test]
#[ignore = "needs root, iproute2 (ip) and tshark: `cargo xtask test` runs it as root"]
fn ethercrab_drives_the_firmware_over_a_veth_pair() {
    if let Some(why) = veth_missing() {
        panic!("this test cannot run here: {why}");
    }
    let (run, board) = std::thread::spawn(|| {
        on_a_veth_pair(
            || {
                let board = firmware_target()?.into_board(|_| {});
                for (ch, v) in AI_LEVELS_V.iter().enumerate() {
                    board.adc().borrow_mut().inputs[ch] = Signal::Constant(*v);
                }
                Ok(board)
            },
            async |md: &MainDevice<'_>| drive_the_firmware(md).await,
        )
    })
    .join()
    .expect("namespace thread")
    .unwrap();
    let stats = &board.stats;
    eprintln!(
        "board answered {} frames over vb1; CPU behind the wall clock: {}",
        stats.frames,
        stats.lag.summary(stats.elapsed)
    );
    // The firmware's identity, from its generated SII and over SDO.
    assert_eq!(run.sii_name, NAMES.order_code);
    assert_eq!(run.sii_product, IDENTITY.product_code);
    assert_eq!(run.sdo_product, IDENTITY.product_code);
    assert_eq!(run.sdo_name, NAMES.device_name);
    // The master's last request was PRE-OP, and the module took it without an error.
    assert_eq!(
        stats.al_status & 0x1F,
        2,
        "AL status {:#06x}",
        stats.al_status
    );
    // Every exchange in OP answered by the slave.
    assert_eq!(
        run.inputs.len(),
        run.exchanges,
        "exchanges with the LRW's working counter {LRW_WKC}"
    );
    // Every input value read in OP is the input's voltage truncated to a 0x6401 step.
    for values in &run.inputs {
        check_inputs(&AI_LEVELS_V, values).unwrap();
    }
    // Every output pair reached the DAC, in order, but for a pair the board's CPU skipped
    // while it ran behind the wall clock for longer than the pair stayed in SM2.
    assert_eq!(run.taken.len(), usize::from(PAIRS));
    let held = EXCHANGE_GAP * u32::from(EXCHANGES_PER_PAIR);
    let on_dac = check_outputs_on_the_wall_clock(
        &run.taken,
        &board.dac_updates,
        &stats.lag,
        held.as_nanos() as u64,
    )
    .unwrap();
    eprintln!("{on_dac}");
    assert_capture_clean(&board.pcap, "system-iface-veth-firmware.pcap");
}

/// Exchanges the echo test runs at most.
const ECHO_EXCHANGES: u16 = 200;

#[test]
#[ignore = "needs root, iproute2 (ip) and tshark: `cargo xtask test` runs it as root"]
fn ethercrab_gets_its_words_echoed_over_a_veth_pair() {
    if let Some(why) = veth_missing() {
        panic!("this test cannot run here: {why}");
    }
    let (exchanges, board) = std::thread::spawn(|| {
        on_a_veth_pair(
            || {
                let mut board = VirtualBoard::new(BoardConfig::new(minimal_io_device()));
                board.set_cpu(Box::new(EchoResponder::new()));
                Ok(board)
            },
            async |md: &MainDevice<'_>| {
                let group = md
                    .init_single_group::<2, 16>(ethercat_now)
                    .await
                    .map_err(|e| format!("init: {e}"))?;
                let sd = group.subdevice(md, 0).map_err(|e| e.to_string())?;
                assert_eq!(sd.name(), "Virtual analog IO");
                assert_eq!(sd.identity().product_id, 0x1234);
                let group = group.into_op(md).await.map_err(|e| format!("OP: {e}"))?;
                // (sent, echoed) per exchange, until the word sent one exchange before
                // comes back.
                let mut exchanges: Vec<(u16, u16)> = Vec::new();
                for i in 0..ECHO_EXCHANGES {
                    let sent = 0x4000 + i;
                    {
                        let sd = group.subdevice(md, 0).map_err(|e| e.to_string())?;
                        sd.outputs_raw_mut().copy_from_slice(&sent.to_le_bytes());
                    }
                    group.tx_rx(md).await.map_err(|e| format!("tx_rx: {e}"))?;
                    let sd = group.subdevice(md, 0).map_err(|e| e.to_string())?;
                    let raw = sd.inputs_raw();
                    exchanges.push((sent, u16::from_le_bytes([raw[0], raw[1]])));
                    if i > 10 && exchanges[exchanges.len() - 1].1 == sent - 1 {
                        break;
                    }
                }
                let group = group
                    .into_safe_op(md)
                    .await
                    .map_err(|e| format!("SAFE-OP: {e}"))?;
                group
                    .into_pre_op(md)
                    .await
                    .map_err(|e| format!("PRE-OP: {e}"))?;
                Ok::<_, String>(exchanges)
            },
        )
    })
    .join()
    .expect("namespace thread")
    .unwrap();
    eprintln!("board answered {} frames over vb1", board.stats.frames);
    assert!(
        board.stats.frames > 100,
        "only {} frames",
        board.stats.frames
    );
    // The master's last request was PRE-OP.
    assert_eq!(
        board.stats.al_status & 0x0F,
        2,
        "AL status {:#06x}",
        board.stats.al_status
    );
    // Each word that came back was sent at an earlier exchange (0 before the first echo),
    // never older than one that came back before it; the last is the word of the exchange
    // before (the echo takes one exchange: the CPU copies SM2 to SM3 after the frame).
    let mut newest = 0;
    for (i, &(_, echoed)) in exchanges.iter().enumerate() {
        let sent_before = exchanges[..i].iter().any(|&(s, _)| s == echoed);
        assert!(
            echoed == 0 || sent_before,
            "exchange {i}: {echoed:#06x} was never sent before ({exchanges:x?})"
        );
        assert!(echoed >= newest, "exchange {i}: an older word came back");
        newest = echoed;
    }
    let n = exchanges.len();
    assert!(
        n < usize::from(ECHO_EXCHANGES),
        "the echo never caught up ({exchanges:x?})"
    );
    assert_eq!(exchanges[n - 1].1, exchanges[n - 2].0, "{exchanges:x?}");
    assert_capture_clean(&board.pcap, "system-iface-veth.pcap");
}
