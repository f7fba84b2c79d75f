//! A CANopen master in process, for tests on virtual time: NMT, SYNC, an SDO client
//! (expedited and segmented, built from coe-core's SDO frames with the client's command
//! specifiers) and raw PDO frames, on its own port of the board's CAN bus. While it waits
//! for an answer it steps the board's time, so it can run between the cycles of an
//! EtherCAT master driving the same board.

use crate::models::can::{PortId, SharedCanBus};
use crate::rig::board::VirtualBoard;
use coe_core::canopen::nmt::NmtCommandRepr;
use coe_core::canopen::{cob, CanFrame, NmtCommand};
use coe_core::wire::{Direction, InitData, Sdo, SdoRepr};
use coe_core::SdoAbortCode;
use std::cell::RefCell;
use std::collections::VecDeque;

/// How long the master waits for an SDO answer (virtual ns).
pub const SDO_TIMEOUT_NS: u64 = 100_000_000;

/// Time step while waiting (virtual ns).
const STEP_NS: u64 = 20_000;

/// Why an SDO exchange failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SdoError {
    /// The server aborted the transfer.
    Abort(SdoAbortCode),
    /// No answer in [`SDO_TIMEOUT_NS`].
    Timeout,
    /// An answer the client cannot use.
    Protocol,
}

/// The master on a port of the bus.
pub struct CanMaster {
    bus: SharedCanBus,
    port: PortId,
    received: RefCell<VecDeque<(u64, CanFrame)>>,
}

impl CanMaster {
    /// Attaches a master to `board`'s bus.
    pub fn attach(board: &VirtualBoard) -> Self {
        let bus = board.can().clone();
        let port = bus.borrow_mut().attach("test master");
        Self {
            bus,
            port,
            received: RefCell::new(VecDeque::new()),
        }
    }

    /// Queues a frame on the bus.
    pub fn send(&self, frame: CanFrame) {
        self.bus.borrow_mut().send(self.port, frame);
    }

    /// An NMT command for `node` (0: all nodes).
    pub fn nmt(&self, command: NmtCommand, node: u8) {
        let data = NmtCommandRepr { command, node }.emit();
        if let Ok(f) = CanFrame::new(cob::NMT, &data) {
            self.send(f);
        }
    }

    /// A SYNC without counter.
    pub fn sync(&self) {
        if let Ok(f) = CanFrame::new(cob::SYNC, &[]) {
            self.send(f);
        }
    }

    fn collect(&self) {
        let mut bus = self.bus.borrow_mut();
        let mut rx = self.received.borrow_mut();
        while let Some(f) = bus.receive(self.port) {
            rx.push_back(f);
        }
    }

    /// Every frame received so far (end time on the bus, frame), oldest first.
    pub fn take(&self) -> Vec<(u64, CanFrame)> {
        self.collect();
        self.received.borrow_mut().drain(..).collect()
    }

    /// Steps `board` until a frame with identifier `id` arrives (taken out of the received
    /// frames; the others stay), at most `timeout_ns`.
    pub fn wait_for(&self, board: &mut VirtualBoard, id: u16, timeout_ns: u64) -> Option<CanFrame> {
        let end = board.now_ns() + timeout_ns;
        loop {
            self.collect();
            let hit = {
                let mut rx = self.received.borrow_mut();
                let i = rx.iter().position(|(_, f)| f.id() == id);
                i.and_then(|i| rx.remove(i))
            };
            if let Some((_, f)) = hit {
                return Some(f);
            }
            if board.now_ns() >= end {
                return None;
            }
            board.step(STEP_NS);
        }
    }

    /// One SDO request to `node` and its answer.
    fn exchange(
        &self,
        board: &mut VirtualBoard,
        node: u8,
        request: &SdoRepr<'_>,
    ) -> Result<[u8; 8], SdoError> {
        let mut data = [0u8; 8];
        request
            .emit(&mut Sdo::new_unchecked(&mut data[..]))
            .map_err(|_| SdoError::Protocol)?;
        let frame =
            CanFrame::new(cob::SDO_RX + u16::from(node), &data).map_err(|_| SdoError::Protocol)?;
        self.send(frame);
        let answer = self
            .wait_for(board, cob::SDO_TX + u16::from(node), SDO_TIMEOUT_NS)
            .ok_or(SdoError::Timeout)?;
        let bytes: [u8; 8] = answer.data().try_into().map_err(|_| SdoError::Protocol)?;
        if let Ok(SdoRepr::Abort { code, .. }) =
            SdoRepr::parse(&Sdo::new_unchecked(&bytes[..]), Direction::Response)
        {
            return Err(SdoError::Abort(code));
        }
        Ok(bytes)
    }

    /// SDO upload of `index:sub` from `node` (expedited or segmented).
    pub fn upload(
        &self,
        board: &mut VirtualBoard,
        node: u8,
        index: u16,
        sub: u8,
    ) -> Result<Vec<u8>, SdoError> {
        let init = SdoRepr::InitiateUploadRequest {
            index,
            sub_index: sub,
            complete_access: false,
        };
        let a = self.exchange(board, node, &init)?;
        let total = match SdoRepr::parse(&Sdo::new_unchecked(&a[..]), Direction::Response) {
            Ok(SdoRepr::InitiateUploadResponse {
                data: d @ InitData::Expedited { .. },
                ..
            }) => return Ok(d.bytes().to_vec()),
            Ok(SdoRepr::InitiateUploadResponse {
                data: InitData::Normal { complete_size, .. },
                ..
            }) => complete_size as usize,
            _ => return Err(SdoError::Protocol),
        };
        let mut value = Vec::with_capacity(total);
        let mut toggle = false;
        loop {
            let a = self.exchange(board, node, &SdoRepr::UploadSegmentRequest { toggle })?;
            match SdoRepr::parse(&Sdo::new_unchecked(&a[..]), Direction::Response) {
                Ok(SdoRepr::UploadSegmentResponse {
                    toggle: t,
                    last,
                    data,
                }) if t == toggle => {
                    value.extend_from_slice(data);
                    if last {
                        return if value.len() == total {
                            Ok(value)
                        } else {
                            Err(SdoError::Protocol)
                        };
                    }
                }
                _ => return Err(SdoError::Protocol),
            }
            toggle = !toggle;
        }
    }

    /// SDO download of `value` to `index:sub` of `node` (expedited up to 4 bytes, else
    /// segmented).
    pub fn download(
        &self,
        board: &mut VirtualBoard,
        node: u8,
        index: u16,
        sub: u8,
        value: &[u8],
    ) -> Result<(), SdoError> {
        let data = InitData::expedited(value).unwrap_or(InitData::Normal {
            complete_size: value.len() as u32,
            data: &[],
        });
        let init = SdoRepr::InitiateDownloadRequest {
            index,
            sub_index: sub,
            complete_access: false,
            data,
        };
        self.exchange(board, node, &init)?;
        if value.len() <= 4 {
            return Ok(());
        }
        let mut toggle = false;
        let chunks: Vec<&[u8]> = value.chunks(7).collect();
        for (i, chunk) in chunks.iter().enumerate() {
            let request = SdoRepr::DownloadSegmentRequest {
                toggle,
                last: i + 1 == chunks.len(),
                data: chunk,
            };
            self.exchange(board, node, &request)?;
            toggle = !toggle;
        }
        Ok(())
    }
}
