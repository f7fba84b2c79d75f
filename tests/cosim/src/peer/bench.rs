//! The side-by-side bench (issue 29): the release image and the peer (SOES) measured the
//! same way on the co-simulated board with ethercrab as the master, the criteria and
//! runs of [`crate::bench`] (`lpc1754-cosim peer-bench`, `cargo xtask bench --peer soes`).
//!
//! Per stack: the sweep for the shortest sustained DC cycle; a run at 1 ms
//! ([`COMPARISON_CYCLE_NS`]) for the CPU load, SYNC0 -> LDAC, the PDI bytes per cycle, the
//! ESM times (from the ESC's log of AL control and AL status writes; the board's ESC lags
//! the CPU by at most [`crate::cosim::BOARD_STEP_NS`], the resolution of these rows) and
//! the stack; SDO service times in PRE-OP, timed in 1 us steps of the board; flash and RAM
//! of the ELF.

use crate::bench::{
    dc_run_program, master, step_to, sweep_program, Board, Plan, Program, Storage, TAIL_CYCLES,
};
use crate::cosim::{Facts, Options};
use crate::run::CosimHandle;
use ethercrab::PduStorage;
use std::cell::RefCell;
use std::rc::Rc;
use virtual_board::models::esc::{AlWrite, Side};
use virtual_board::rig::master::tx_rx_task;
use virtual_board::rig::sdo_client::{
    request, sdo_request_bytes, sdo_response, MailboxClient, MAILBOX_TYPE_COE,
};
use virtual_board::tools::peer_figures::{StackFigures, COMPARISON_CYCLE_NS};

/// An expedited SDO request the service-time rows time.
#[derive(Clone, Copy, Debug)]
pub enum SdoRequest {
    /// Upload of index:sub.
    Upload(u16, u8),
    /// Download of 4 bytes to index:sub.
    Download(u16, u8, [u8; 4]),
}

/// How often each SDO request is timed (the rows give the mean).
const SDO_REPETITIONS: u32 = 5;
/// The longest a reply may take (ns) before the timing gives up.
const SDO_LIMIT_NS: u64 = 20_000_000;
/// The board's step while waiting for a reply (ns): the SDO rows' resolution.
const SDO_STEP_NS: u64 = 1_000;

/// The program on a fresh board (its SII, its CPU) and the handle on its co-simulator.
pub fn board_for(program: &Program) -> Result<(Board, CosimHandle), String> {
    let (target, handle) = (program.target)(program.image.clone(), Options::default())?;
    let board = Rc::new(RefCell::new(target.into_board(|cfg| cfg.capture = false)));
    Ok((board, handle))
}

/// The mailbox client of both stacks' layout (SM0 0x1000, SM1 0x1080, 128 B each).
pub fn mailbox_client() -> MailboxClient<128> {
    MailboxClient::new(0x1000, 0x1080, 1)
}

/// Mean service time (ns) of each of `requests` in PRE-OP: the request complete in SM0 ->
/// the reply complete in SM1, the board stepped [`SDO_STEP_NS`] at a time.
pub fn sdo_service_ns(program: &Program, requests: &[SdoRequest]) -> Result<Vec<f64>, String> {
    let (board, _handle) = board_for(program)?;
    let storage: Box<Storage> = Box::new(PduStorage::new());
    let (md, tx, rx) = master(&storage)?;
    let run = async {
        let clock = board.borrow().clock().clone();
        let group = md
            .init_single_group::<2, 64>(|| clock.now_ns())
            .await
            .map_err(|e| format!("INIT -> PRE-OP: {e}"))?;
        let sd = group.subdevice(&md, 0).map_err(|e| e.to_string())?;
        let mut mbx = mailbox_client();
        let mut means = Vec::new();
        for req in requests {
            let payload = sdo_request_bytes(&match *req {
                SdoRequest::Upload(index, sub) => request::initiate_upload(index, sub, false),
                SdoRequest::Download(index, sub, data) => {
                    request::expedited_download(index, sub, &data)
                }
            });
            let mut total = 0u64;
            for _ in 0..SDO_REPETITIONS {
                if !mbx.send(&sd, MAILBOX_TYPE_COE, &payload).await? {
                    return Err(format!("{req:?}: SM0 stayed full"));
                }
                let t0 = board.borrow().now_ns();
                loop {
                    let now = board.borrow().now_ns();
                    if board.borrow().esc().borrow().sm_mailbox_full(1) {
                        total += now - t0;
                        break;
                    }
                    if now - t0 > SDO_LIMIT_NS {
                        return Err(format!(
                            "{req:?}: no reply in {} ms",
                            SDO_LIMIT_NS / 1_000_000
                        ));
                    }
                    step_to(&board, now + SDO_STEP_NS);
                }
                let reply = mbx.read(&sd).await?;
                sdo_response(&reply).map_err(|e| format!("{req:?}: {e}"))?;
            }
            means.push(total as f64 / f64::from(SDO_REPETITIONS));
        }
        Ok(means)
    };
    futures_lite::future::block_on(futures_lite::future::or(
        run,
        tx_rx_task(board.clone(), tx, rx),
    ))
}

/// The slave's time (ns) for INIT -> PRE-OP, PRE-OP -> SAFE-OP, SAFE-OP -> OP: from the
/// master's AL control write requesting the state to the slave's first AL status write
/// showing it.
pub fn esm_times(log: &[AlWrite]) -> Result<[u64; 3], String> {
    let mut out = [0; 3];
    for (i, state) in [0x02u16, 0x04, 0x08].into_iter().enumerate() {
        let request = log
            .iter()
            .position(|w| w.side == Side::Ecat && w.value & 0x0F == state)
            .ok_or_else(|| format!("the master never requested state {state:#x}"))?;
        let done = log[request..]
            .iter()
            .find(|w| w.side == Side::Pdi && w.value & 0x1F == state)
            .ok_or_else(|| format!("the slave never showed state {state:#x}"))?;
        out[i] = done.time_ns - log[request].time_ns;
    }
    Ok(out)
}

/// ET1100 SPI bytes per cycle between two facts `cycles` cycles apart.
fn bytes_per_cycle(before: &Facts, after: &Facts, cycles: u64) -> f64 {
    (after.traffic.esc_bytes - before.traffic.esc_bytes) as f64 / cycles.max(1) as f64
}

/// How long the master waits before its first frame in these runs: both programs are up
/// (ours: the bootloader's checks, then the application, about 10 ms), so the ESM rows time
/// the transitions, not the boot.
pub const BOOT_NS: u64 = 20_000_000;

/// Everything for one stack.
pub fn measure_stack(
    name: &str,
    elf: &str,
    program: &Program,
    sdo: [SdoRequest; 2],
    plan: &Plan,
    progress: &mut dyn FnMut(&str),
) -> Result<StackFigures, String> {
    let program = &Program {
        boot_ns: BOOT_NS,
        ..*program
    };
    let cycles = plan.profile_cycles;
    progress(&format!(
        "{name}: {cycles} DC cycles of {} us",
        COMPARISON_CYCLE_NS / 1000
    ));
    let run = dc_run_program(program, COMPARISON_CYCLE_NS, cycles, false, None)?;
    if let Some(f) = &run.check.failure {
        return Err(format!("{name} at 1 ms: {f}"));
    }
    let before = run
        .before
        .as_ref()
        .ok_or("the run reached no process data")?;
    let pdi_bytes_per_cycle = bytes_per_cycle(before, &run.after, cycles + TAIL_CYCLES);
    let esm_ns = esm_times(&run.al_log)?;
    progress(&format!("{name}: SDO service times"));
    let sdo_ns = sdo_service_ns(program, &sdo)?;
    let sdo_objects = sdo
        .iter()
        .map(|r| match r {
            SdoRequest::Upload(i, s) => format!("upload {i:#06x}:{s}"),
            SdoRequest::Download(i, s, _) => format!("download {i:#06x}:{s}"),
        })
        .collect::<Vec<_>>()
        .join(", ");
    // The peer's figures stay the ideal master's: its dictionary has none of the objects the
    // image's SDO traffic reads.
    let traffic = crate::traffic::Traffic::IDEAL;
    let sweep = sweep_program(program, plan, None, &traffic, &mut |c| {
        progress(&format!(
            "{name}: cycle {:.1} us: {} (CPU load {:.1} %)",
            c.cycle_ns as f64 / 1e3,
            c.verdict(),
            100.0 * c.cpu_load
        ))
    });
    Ok(StackFigures {
        name: name.to_string(),
        elf: elf.to_string(),
        sweep,
        at_comparison_cycle: run.check.clone(),
        pdi_bytes_per_cycle,
        sdo_upload_ns: sdo_ns[0],
        sdo_download_ns: sdo_ns[1],
        sdo_objects,
        esm_ns,
        flash_bytes: u64::from(program.image.flash_bytes),
        static_ram_bytes: u64::from(program.image.static_ram),
        stack_bytes: u64::from(run.after.stack_used),
    })
}
