//! SYSTEM TEST: the virtual board on a Linux network interface ([`virtual_board::tools::iface`])
//! with ethercrab's own raw-socket networking on the other end of a veth pair.
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
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;
use virtual_board::rig::board::{BoardConfig, VirtualBoard};
use virtual_board::rig::sii_builder::minimal_io_device;
use virtual_board::tools::iface::{
    ip, serve, veth_missing, veth_pair_in_new_namespace, RawSocket, ServeOptions,
};
use virtual_board::tools::sim::responder::EchoResponder;

struct Outcome {
    frames: u64,
    al_status: u16,
    pcap: Vec<u8>,
    echoed: Vec<u8>,
}

fn run_in_namespace() -> Result<Outcome, String> {
    veth_pair_in_new_namespace("vb0", "vb1")?;

    let stop = Arc::new(AtomicBool::new(false));
    let board_stop = stop.clone();
    let (ready_tx, ready_rx) = std::sync::mpsc::channel();
    let board_thread = std::thread::spawn(move || {
        let sock = RawSocket::open("vb1").map_err(|e| e.to_string())?;
        let mut board = VirtualBoard::new(BoardConfig::new(minimal_io_device()));
        board.set_cpu(Box::new(EchoResponder::new()));
        ready_tx.send(()).ok();
        let opts = ServeOptions {
            // Bounded even if the master never finishes.
            duration: Some(Duration::from_secs(30)),
            ..Default::default()
        };
        let stats = serve(&mut board, &sock, &board_stop, &opts, &mut |s| {
            eprintln!("board: {} frames, AL status {:#06x}", s.frames, s.al_status)
        })
        .map_err(|e| e.to_string())?;
        let pcap = board.pcap().unwrap().bytes().to_vec();
        Ok::<_, String>((stats, pcap))
    });
    ready_rx
        .recv_timeout(Duration::from_secs(5))
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
    let master = async {
        let group = md
            .init_single_group::<2, 16>(ethercat_now)
            .await
            .map_err(|e| format!("init: {e}"))?;
        let sd = group.subdevice(&md, 0).map_err(|e| e.to_string())?;
        assert_eq!(sd.name(), "Virtual analog IO");
        assert_eq!(sd.identity().product_id, 0x1234);
        let group = group.into_op(&md).await.map_err(|e| format!("OP: {e}"))?;
        let mut echoed = Vec::new();
        for i in 0..200u16 {
            {
                let sd = group.subdevice(&md, 0).map_err(|e| e.to_string())?;
                sd.outputs_raw_mut()
                    .copy_from_slice(&(0x4000 + i).to_le_bytes());
            }
            group.tx_rx(&md).await.map_err(|e| format!("tx_rx: {e}"))?;
            let sd = group.subdevice(&md, 0).map_err(|e| e.to_string())?;
            echoed = sd.inputs_raw().to_vec();
            if i > 10 && echoed == (0x4000 + i - 1).to_le_bytes() {
                break;
            }
        }
        let group = group
            .into_safe_op(&md)
            .await
            .map_err(|e| format!("SAFE-OP: {e}"))?;
        group
            .into_pre_op(&md)
            .await
            .map_err(|e| format!("PRE-OP: {e}"))?;
        Ok::<_, String>(echoed)
    };
    let result = futures_lite::future::block_on(futures_lite::future::or(master, async {
        match net.await {
            Ok(_) => Err("ethercrab's network task ended".to_string()),
            Err(e) => Err(format!("ethercrab's network task failed: {e}")),
        }
    }));
    stop.store(true, Ordering::Relaxed);
    let (stats, pcap) = board_thread
        .join()
        .map_err(|_| "the board thread panicked".to_string())??;
    let echoed = result?;
    // Tidy up explicitly too (the namespace takes the pair with it anyway).
    let _ = ip("link del vb0");
    Ok(Outcome {
        frames: stats.frames,
        al_status: stats.al_status,
        pcap,
        echoed,
    })
}

#[test]
#[ignore = "needs root, iproute2 (ip) and tshark: `cargo xtask test` runs it as root"]
fn ethercrab_drives_the_board_over_a_veth_pair() {
    if let Some(why) = veth_missing() {
        panic!("this test cannot run here: {why}");
    }
    let o = std::thread::spawn(run_in_namespace)
        .join()
        .expect("namespace thread")
        .unwrap();
    eprintln!("board answered {} frames over vb1", o.frames);
    assert!(o.frames > 100, "only {} frames", o.frames);
    // The master's last request was PRE-OP.
    assert_eq!(o.al_status & 0x0F, 2, "AL status {:#06x}", o.al_status);
    // The SM2 word came back through SM3 (the echo), as the master read it.
    assert_eq!(o.echoed.len(), 2);
    assert!(u16::from_le_bytes([o.echoed[0], o.echoed[1]]) >= 0x4000);
    let path = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("system-iface-veth.pcap");
    std::fs::write(&path, &o.pcap).unwrap();
    virtual_board::tools::sim::tshark::assert_clean(&path);
}
