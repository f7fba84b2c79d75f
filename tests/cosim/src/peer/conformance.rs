//! The conformance the project's system tests encode, run against this project's release
//! image and against the peer (SOES) on the same co-simulated board (issue 29): mailbox
//! counter and repeat, mailbox error replies, SDO aborts, complete access, SDO Information,
//! ESM errors, the SM watchdog, the DC cycle check. Every check starts from a fresh board
//! brought to PRE-OP by ethercrab; its outcome is a [`Verdict`] per stack, and
//! `virtual_board::tools::peer_figures::conformance_table` prints them side by side (`lpc1754-cosim peer-bench`, `cargo xtask bench
//! --peer soes`, the test `peer_conformance`).

use crate::bench::{master, step_to, Board, Program, Storage};
use crate::peer::bench::{board_for, mailbox_client};
use ethercrab::subdevice_group::DcConfiguration;
use ethercrab::{MainDevice, PduStorage, SubDevice, SubDeviceRef};
use std::ops::Deref;
use std::time::Duration;
use virtual_board::models::esc::regs;
use virtual_board::rig::master::tx_rx_task;
use virtual_board::rig::sdo_client::MailboxClient;
use virtual_board::rig::sdo_client::{
    mailbox_type, payload, request, sdo_request_bytes, sdo_response, SdoError, MAILBOX_TYPE_COE,
    MAILBOX_TYPE_ERROR,
};
use virtual_board::tools::peer_figures::{ConformanceRow, Verdict};

/// What differs between the stacks for the checks: nothing of the behaviour, only which
/// object takes a 32-bit download.
#[derive(Clone, Copy, Debug)]
pub struct Profile {
    /// A writable 32-bit object (index, sub): 0x6444:01 (fault value) on ours, 0x10F1:01
    /// (local error reaction) on SOES.
    pub writable_u32: (u16, u8),
}

/// The checks, in table order: (area, requirement).
pub const CHECKS: [(&str, &str); 19] = [
    ("mailbox", "a request repeating the previous counter is a retry: dropped, no second reply (ETG.1000.4 5.6.2)"),
    ("mailbox", "the repeat request (SM1 toggle) returns the last reply again, acknowledged in 0x080F (ESC I 8.6)"),
    ("mailbox", "an unknown mailbox type gets a mailbox error reply 0x0002 unsupported protocol (ETG.1000.4 table 29)"),
    ("mailbox", "a header of length 0 gets a mailbox error reply"),
    ("SDO", "upload of an object that does not exist: abort 0x06020000"),
    ("SDO", "upload of a subindex that does not exist (0x1018:32): abort 0x06090011"),
    ("SDO", "download to a read-only object (0x1000): abort 0x06010002"),
    ("SDO", "download of 2 bytes to a 32-bit object: abort 0x0607001x (length does not match)"),
    ("SDO", "an unknown command specifier: abort 0x05040001"),
    ("SDO", "upload of 0x1008 (more than 4 bytes): a normal upload with the whole string"),
    ("complete access", "complete-access upload of 0x1018: subindex 0 and the four entries (18 bytes)"),
    ("complete access", "complete-access download to 0x1018 (read-only): an abort"),
    ("SDO Information", "OD list (all objects) with 0x1000, 0x1018, 0x1C12, 0x1C13"),
    ("SDO Information", "object description of 0x1018: RECORD, max subindex 4"),
    ("SDO Information", "entry description of 0x1018:02: UNSIGNED32, 32 bits, readable"),
    ("SDO Information", "object description of an object that does not exist: SDO Information error 0x06020000"),
    ("ESM", "INIT -> SAFE-OP refused: INIT + error, 0x0011; the error acknowledge clears it"),
    ("ESM", "a state that does not exist (0x06): error, 0x0012"),
    ("ESM", "INIT -> PRE-OP with SM0 of the wrong length: INIT + error, 0x0016"),
];

/// The checks that need more than PRE-OP, after [`CHECKS`] in the table.
pub const FLOW_CHECKS: [(&str, &str); 3] = [
    (
        "ESM",
        "PRE-OP -> SAFE-OP with SM2 of the wrong length: PRE-OP + error, 0x001D",
    ),
    (
        "watchdog",
        "in OP, process data stopped: SAFE-OP + error, 0x001B (SM watchdog, 100 ms)",
    ),
    (
        "DC",
        "a SYNC0 cycle below 0x1C32:05: PRE-OP + error, 0x0035 or 0x0036",
    ),
];

type Sd<'a, 'g> = SubDeviceRef<'a, &'g SubDevice>;

/// The expedited SDO request bytes of an upload.
fn upload(index: u16, sub: u8) -> Vec<u8> {
    sdo_request_bytes(&request::initiate_upload(index, sub, false))
}

/// Sends `payload` (CoE) and reads the reply. One client per check: its counter runs on
/// (ethercrab's own mailbox is not used by the checks, so no counter repeats).
async fn exchange<S>(
    mbx: &mut MailboxClient<128>,
    sd: &SubDeviceRef<'_, S>,
    payload: &[u8],
) -> Result<[u8; 128], String>
where
    S: Deref<Target = SubDevice>,
{
    if mbx.send(sd, MAILBOX_TYPE_COE, payload).await? {
        mbx.read(sd).await
    } else {
        Err("the write mailbox stayed full".into())
    }
}

/// An abort with `code` (or one of `codes`) expected.
fn expect_abort(reply: &[u8], codes: &[u32]) -> Result<String, String> {
    match sdo_response(reply) {
        Err(SdoError::Abort { code, .. }) if codes.contains(&code) => {
            Ok(format!("abort {code:#010x}"))
        }
        Err(e) => Err(format!("{e}")),
        Ok(sdo) => Err(format!(
            "no abort: response {:02x?}",
            &sdo[..sdo.len().min(8)]
        )),
    }
}

/// AL status and AL status code after writing `control` to AL control, once the slave
/// answered (AL status shows the state without error, or an error it did not show
/// before; after an acknowledge, no error) or 50 ms passed.
async fn request_state<S>(
    board: &Board,
    sd: &SubDeviceRef<'_, S>,
    control: u16,
) -> Result<(u16, u16), String>
where
    S: Deref<Target = SubDevice>,
{
    let e = |e: ethercrab::error::Error| e.to_string();
    let before: u16 = sd.register_read(regs::AL_STATUS).await.map_err(e)?;
    sd.register_write(regs::AL_CONTROL, control)
        .await
        .map_err(e)?;
    let t0 = board.borrow().now_ns();
    let acknowledge = control & 0x10 != 0;
    loop {
        let status: u16 = sd.register_read(regs::AL_STATUS).await.map_err(e)?;
        let reached = status & 0x1F == control & 0x0F;
        let refused = !acknowledge && status & 0x10 != 0 && status != before;
        if reached || refused || board.borrow().now_ns() - t0 > 50_000_000 {
            let code: u16 = sd.register_read(regs::AL_STATUS_CODE).await.map_err(e)?;
            return Ok((status, code));
        }
        let now = board.borrow().now_ns();
        step_to(board, now + 100_000);
    }
}

/// SDO Information request: opcode, then `data` (ETG.1000.6 5.6.3); the reply's SDO
/// Information header opcode and data (fragments joined).
async fn sdo_info<S>(
    sd: &SubDeviceRef<'_, S>,
    opcode: u8,
    data: &[u8],
) -> Result<(u8, Vec<u8>), String>
where
    S: Deref<Target = SubDevice>,
{
    let mut p = vec![0x00, 0x80, opcode, 0, 0, 0];
    p.extend_from_slice(data);
    let mut mbx = mailbox_client();
    if !mbx.send(sd, MAILBOX_TYPE_COE, &p).await? {
        return Err("the write mailbox stayed full".into());
    }
    let mut out = Vec::new();
    for _ in 0..32 {
        let frame = mbx.read(sd).await?;
        if mailbox_type(&frame) != MAILBOX_TYPE_COE {
            return Err(format!("mailbox type {} in reply", mailbox_type(&frame)));
        }
        let body = payload(&frame)?;
        if body.len() < 6 || u16::from_le_bytes([body[0], body[1]]) >> 12 != 8 {
            return Err(format!(
                "not an SDO Information reply: {:02x?}",
                &body[..body.len().min(8)]
            ));
        }
        let op = body[2] & 0x7F;
        out.extend_from_slice(&body[6..]);
        if body[2] & 0x80 == 0 {
            return Ok((op, out));
        }
    }
    Err("more than 32 fragments".into())
}

/// One PRE-OP check (`n` indexes [`CHECKS`]).
async fn preop_check(
    n: usize,
    board: &Board,
    sd: &Sd<'_, '_>,
    p: &Profile,
) -> Result<String, String> {
    let e = |e: ethercrab::error::Error| e.to_string();
    let mut mbx = mailbox_client();
    match n {
        0 => {
            let frame = MailboxClient::<128>::frame(MAILBOX_TYPE_COE, 3, &upload(0x1000, 0));
            mbx.send_raw(sd, &frame).await?;
            mbx.read(sd).await?;
            mbx.send_raw(sd, &frame).await?;
            for _ in 0..50 {
                if mbx.reply_waiting(sd).await? {
                    return Err("the retry got a second reply".into());
                }
            }
            Ok("dropped".into())
        }
        1 => {
            mbx.send(sd, MAILBOX_TYPE_COE, &upload(0x1018, 1)).await?;
            let first = mbx.read(sd).await?;
            let again = mbx.repeat(sd).await?;
            if again == first {
                Ok("same reply".into())
            } else {
                Err("a different frame".into())
            }
        }
        2 | 3 => {
            let mut frame = MailboxClient::<128>::frame(0x0F, 2, &upload(0x1000, 0));
            if n == 3 {
                frame[..2].copy_from_slice(&[0, 0]);
                frame[5] = (2 << 4) | MAILBOX_TYPE_COE;
            }
            mbx.send_raw(sd, &frame).await?;
            let reply = mbx.read(sd).await?;
            if mailbox_type(&reply) != MAILBOX_TYPE_ERROR {
                return Err(format!("reply of type {}", mailbox_type(&reply)));
            }
            let detail = u16::from_le_bytes([reply[8], reply[9]]);
            if n == 2 && detail != 0x0002 {
                return Err(format!("mailbox error {detail:#06x}"));
            }
            Ok(format!("mailbox error {detail:#06x}"))
        }
        4 => expect_abort(
            &exchange(&mut mbx, sd, &upload(0x5FFE, 0)).await?,
            &[0x0602_0000],
        ),
        5 => expect_abort(
            &exchange(&mut mbx, sd, &upload(0x1018, 32)).await?,
            &[0x0609_0011],
        ),
        6 => {
            let r = sdo_request_bytes(&request::expedited_download(0x1000, 0, &[1, 2, 3, 4]));
            expect_abort(&exchange(&mut mbx, sd, &r).await?, &[0x0601_0002])
        }
        7 => {
            let (i, s) = p.writable_u32;
            let r = sdo_request_bytes(&request::expedited_download(i, s, &[1, 0]));
            expect_abort(
                &exchange(&mut mbx, sd, &r).await?,
                &[0x0607_0010, 0x0607_0012, 0x0607_0013],
            )
        }
        8 => {
            let r = sdo_request_bytes(&[0xE0, 0x00, 0x10, 0x00, 0, 0, 0, 0]);
            expect_abort(&exchange(&mut mbx, sd, &r).await?, &[0x0504_0001])
        }
        9 => {
            let reply = exchange(&mut mbx, sd, &upload(0x1008, 0)).await?;
            let sdo = sdo_response(&reply).map_err(|e| e.to_string())?;
            if sdo[0] & 0x02 != 0 {
                return Err("expedited".into());
            }
            let len = u32::from_le_bytes([sdo[4], sdo[5], sdo[6], sdo[7]]) as usize;
            let name =
                String::from_utf8_lossy(sdo.get(8..8 + len).unwrap_or_default()).into_owned();
            if len > 4 && name.len() == len {
                Ok(format!("{len} bytes, {name:?}"))
            } else {
                Err(format!("{name:?} ({len} bytes declared)"))
            }
        }
        10 => {
            let r = sdo_request_bytes(&request::initiate_upload(0x1018, 0, true));
            let sdo =
                sdo_response(&exchange(&mut mbx, sd, &r).await?).map_err(|e| e.to_string())?;
            let len = if sdo[0] & 0x02 != 0 {
                4
            } else {
                u32::from_le_bytes([sdo[4], sdo[5], sdo[6], sdo[7]])
            };
            let data = sdo.get(8..).unwrap_or_default();
            if len == 18 && data.len() >= 18 && data[0] == 4 {
                Ok("18 bytes, subindex 0 = 4".into())
            } else {
                Err(format!("{len} bytes: {:02x?}", &data[..data.len().min(18)]))
            }
        }
        11 => {
            let mut r = vec![0x21 | 0x10, 0x18, 0x10, 0x00];
            r.extend_from_slice(&18u32.to_le_bytes());
            r.extend_from_slice(&[4, 0]);
            r.extend_from_slice(&[0; 16]);
            match sdo_response(&exchange(&mut mbx, sd, &sdo_request_bytes(&r)).await?) {
                Err(SdoError::Abort { code, .. }) => Ok(format!("abort {code:#010x}")),
                Err(e) => Err(e.to_string()),
                Ok(_) => Err("accepted".into()),
            }
        }
        12 => {
            let (op, data) = sdo_info(sd, 0x01, &1u16.to_le_bytes()).await?;
            if op != 0x02 {
                return Err(format!("opcode {op:#04x}"));
            }
            let list: Vec<u16> = data
                .get(2..)
                .unwrap_or_default()
                .chunks(2)
                .filter(|c| c.len() == 2)
                .map(|c| u16::from_le_bytes([c[0], c[1]]))
                .collect();
            let missing: Vec<String> = [0x1000u16, 0x1018, 0x1C12, 0x1C13]
                .iter()
                .filter(|i| !list.contains(i))
                .map(|i| format!("{i:#06x}"))
                .collect();
            if missing.is_empty() {
                Ok(format!("{} objects", list.len()))
            } else {
                Err(format!(
                    "{} objects, missing {}",
                    list.len(),
                    missing.join(", ")
                ))
            }
        }
        13 => {
            let (op, d) = sdo_info(sd, 0x03, &0x1018u16.to_le_bytes()).await?;
            match (op, d.get(4), d.get(5)) {
                (0x04, Some(4), Some(9)) => Ok("RECORD, 4".into()),
                _ => Err(format!("opcode {op:#04x}, {:02x?}", &d[..d.len().min(6)])),
            }
        }
        14 => {
            let (op, d) = sdo_info(sd, 0x05, &[0x18, 0x10, 2, 0]).await?;
            let field = |i: usize| d.get(i..i + 2).map(|b| u16::from_le_bytes([b[0], b[1]]));
            match (op, field(4), field(6), field(8)) {
                (0x06, Some(0x0007), Some(32), Some(a)) if a & 0x07 != 0 => {
                    Ok(format!("access {a:#06x}"))
                }
                _ => Err(format!("opcode {op:#04x}, {:02x?}", &d[..d.len().min(10)])),
            }
        }
        15 => {
            let (op, d) = sdo_info(sd, 0x03, &0x5FFEu16.to_le_bytes()).await?;
            let code = d
                .get(0..4)
                .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
            match (op, code) {
                (0x07, Some(0x0602_0000)) => Ok("error 0x06020000".into()),
                _ => Err(format!("opcode {op:#04x}, code {code:x?}")),
            }
        }
        16 => {
            request_state(board, sd, 0x01).await?;
            let (status, code) = request_state(board, sd, 0x04).await?;
            if (status, code) != (0x11, 0x0011) {
                return Err(format!("AL status {status:#06x}, code {code:#06x}"));
            }
            let (status, _) = request_state(board, sd, 0x11).await?;
            if status != 0x01 {
                return Err(format!("after the acknowledge: AL status {status:#06x}"));
            }
            Ok("0x0011, acknowledged".into())
        }
        17 => {
            let (status, code) = request_state(board, sd, 0x06).await?;
            if status & 0x10 != 0 && code == 0x0012 {
                Ok(format!("AL status {status:#06x}, 0x0012"))
            } else {
                Err(format!("AL status {status:#06x}, code {code:#06x}"))
            }
        }
        18 => {
            request_state(board, sd, 0x01).await?;
            let mut sm = [0u8; 8];
            sm[0..2].copy_from_slice(&0x1000u16.to_le_bytes());
            sm[2..4].copy_from_slice(&64u16.to_le_bytes());
            sm[4] = 0x26;
            sm[6] = 0x01;
            // SyncManager registers take writes only while the SM is off (ESC II 3.8).
            sd.register_write(0x0806u16, 0u8).await.map_err(e)?;
            sd.register_write(0x0800u16, sm).await.map_err(e)?;
            let (status, code) = request_state(board, sd, 0x02).await?;
            if (status, code) == (0x11, 0x0016) {
                Ok("0x0016".into())
            } else {
                Err(format!("AL status {status:#06x}, code {code:#06x}"))
            }
        }
        _ => Err("no such check".into()),
    }
}

/// Runs `check` on a fresh board of `program` with ethercrab as the master.
fn on_board<F>(program: &Program, check: F) -> Result<String, String>
where
    F: for<'a> AsyncFnOnce(&'a Board, &'a MainDevice<'a>) -> Result<String, String>,
{
    let (board, handle) = board_for(program)?;
    let storage: Box<Storage> = Box::new(PduStorage::new());
    let (md, tx, rx) = master(&storage)?;
    let result = futures_lite::future::block_on(futures_lite::future::or(
        check(&board, &md),
        tx_rx_task(board.clone(), tx, rx),
    ));
    match handle.with(|c| c.facts()) {
        Some(f) if f.fault.is_some() => Err(format!("the image faulted: {}", f.summary())),
        _ => result,
    }
}

/// One check of [`FLOW_CHECKS`] (`n` indexes it).
async fn flow_check(
    n: usize,
    board: &Board,
    md: &MainDevice<'_>,
    min_cycle_ns: u64,
) -> Result<String, String> {
    let e = |e: ethercrab::error::Error| e.to_string();
    let clock = board.borrow().clock().clone();
    let group = md
        .init_single_group::<2, 64>(|| clock.now_ns())
        .await
        .map_err(|e| format!("INIT -> PRE-OP: {e}"))?;
    match n {
        0 => {
            let group = group.into_pre_op_pdi(md).await.map_err(e)?;
            let sd = group.subdevice(md, 0).map_err(e)?;
            let mut sm2: [u8; 8] = sd.register_read(0x0810u16).await.map_err(e)?;
            sm2[2..4].copy_from_slice(&2u16.to_le_bytes());
            sd.register_write(0x0816u16, 0u8).await.map_err(e)?;
            sd.register_write(0x0810u16, sm2).await.map_err(e)?;
            let (status, code) = request_state(board, &sd, 0x04).await?;
            if (status, code) == (0x12, 0x001D) {
                Ok("0x001D".into())
            } else {
                Err(format!("AL status {status:#06x}, code {code:#06x}"))
            }
        }
        1 => {
            let group = group.into_pre_op_pdi(md).await.map_err(e)?;
            let group = group.into_safe_op(md).await.map_err(e)?;
            let group = group
                .into_op(md)
                .await
                .map_err(|x| format!("SAFE-OP -> OP: {x}"))?;
            for _ in 0..20 {
                group.tx_rx(md).await.map_err(e)?;
                let now = board.borrow().now_ns();
                step_to(board, now + 1_000_000);
            }
            let now = board.borrow().now_ns();
            step_to(board, now + 300_000_000);
            let sd = group.subdevice(md, 0).map_err(e)?;
            let status: u16 = sd.register_read(regs::AL_STATUS).await.map_err(e)?;
            let code: u16 = sd.register_read(regs::AL_STATUS_CODE).await.map_err(e)?;
            if (status, code) == (0x14, 0x001B) {
                Ok("0x001B".into())
            } else {
                Err(format!("AL status {status:#06x}, code {code:#06x}"))
            }
        }
        _ => {
            let mut group = group;
            for mut sd in group.iter_mut(md) {
                sd.set_dc_sync(ethercrab::DcSync::Sync0);
            }
            let group = group.into_pre_op_pdi(md).await.map_err(e)?;
            let cycle = min_cycle_ns / 2;
            let group = group
                .configure_dc_sync(
                    md,
                    DcConfiguration {
                        // One cycle more: ethercrab rounds the first pulse down.
                        start_delay: Duration::from_nanos(1_000_000 + cycle),
                        sync0_period: Duration::from_nanos(cycle),
                        sync0_shift: Duration::ZERO,
                    },
                )
                .await
                .map_err(e)?;
            let sd = group.subdevice(md, 0).map_err(e)?;
            let (status, code) = request_state(board, &sd, 0x04).await?;
            if status == 0x12 && (code == 0x0035 || code == 0x0036) {
                Ok(format!("{} us: {code:#06x}", cycle / 1000))
            } else {
                Err(format!(
                    "{} us: AL status {status:#06x}, code {code:#06x}",
                    cycle / 1000
                ))
            }
        }
    }
}

/// Every check against `program`: (area, requirement, verdict).
pub fn run_all(program: &Program, profile: &Profile) -> Vec<Verdict> {
    let verdict = |r: Result<String, String>| match r {
        Ok(detail) => Verdict { pass: true, detail },
        Err(detail) => Verdict {
            pass: false,
            detail,
        },
    };
    let mut out = Vec::new();
    for n in 0..CHECKS.len() {
        out.push(verdict(on_board(program, async |board, md| {
            let clock = board.borrow().clock().clone();
            let group = md
                .init_single_group::<2, 64>(|| clock.now_ns())
                .await
                .map_err(|e| format!("INIT -> PRE-OP: {e}"))?;
            let sd = group.subdevice(md, 0).map_err(|e| e.to_string())?;
            preop_check(n, board, &sd, profile).await
        })));
    }
    for n in 0..FLOW_CHECKS.len() {
        let min = program.min_cycle_ns;
        out.push(verdict(on_board(program, async |board, md| {
            flow_check(n, board, md, min).await
        })));
    }
    out
}

/// The rows of both stacks' verdicts.
pub fn rows(ours: Vec<Verdict>, peer: Vec<Verdict>) -> Vec<ConformanceRow> {
    CHECKS
        .iter()
        .chain(FLOW_CHECKS.iter())
        .zip(ours.into_iter().zip(peer))
        .map(|((area, check), (ours, peer))| ConformanceRow {
            area: area.to_string(),
            check: check.to_string(),
            ours,
            peer,
        })
        .collect()
}
