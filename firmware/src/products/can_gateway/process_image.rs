//! The EtherCAT process image of the gateway: which nodes' PDOs it carries (the PDO
//! assignment 0x1C12 / 0x1C13, written in PREOP as TwinCAT does for the modules it has),
//! and where each node's 16 bytes sit in it. The mapping of each EtherCAT PDO is fixed
//! (`super::od`): RxPDO 0x1600 + n carries node place n's outputs, TxPDO 0x1A00 + n its
//! inputs, TxPDO 0x1A80 the gateway status; so an image is the assigned PDOs' blocks in
//! assignment order.

use super::od::{
    MAX_NODES, NODE_BYTES, RXPDO_BASE, RX_ASSIGN_DEFAULT, RX_ASSIGN_MAX, STATUS_BYTES,
    STATUS_TXPDO, TXPDO_BASE, TX_ASSIGN_DEFAULT, TX_ASSIGN_MAX,
};
use crate::stacks::entry_bytes::put_le;
use coe_core::device::{sm_control, SyncManagerDesc};
use coe_core::{AlStatusCode, SdoAbortCode};
use et1100::SyncManager;

/// What a PDO of the image carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Block {
    /// Node place n's data.
    Node(usize),
    /// The gateway status (inputs).
    Status,
}

impl Block {
    /// Its bytes in the image.
    pub const fn bytes(self) -> usize {
        match self {
            Self::Node(_) => NODE_BYTES,
            Self::Status => STATUS_BYTES,
        }
    }
}

/// The block an assigned PDO index stands for.
pub fn block_of(tx: bool, pdo: u16) -> Option<Block> {
    let (base, status) = if tx {
        (TXPDO_BASE, Some(STATUS_TXPDO))
    } else {
        (RXPDO_BASE, None)
    };
    if Some(pdo) == status {
        return Some(Block::Status);
    }
    let n = usize::from(pdo.checked_sub(base)?);
    (n < MAX_NODES).then_some(Block::Node(n))
}

/// One direction's assignment.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Assignment<const N: usize> {
    pdos: [u16; N],
    count: u8,
    tx: bool,
}

impl<const N: usize> Assignment<N> {
    const fn new(defaults: [u16; N], tx: bool) -> Self {
        Self {
            pdos: defaults,
            count: N as u8,
            tx,
        }
    }

    /// The assigned PDOs.
    pub fn pdos(&self) -> &[u16] {
        self.pdos
            .get(..usize::from(self.count))
            .unwrap_or(&self.pdos)
    }

    /// The blocks in image order.
    pub fn blocks(&self) -> impl Iterator<Item = Block> + '_ {
        self.pdos().iter().filter_map(|p| block_of(self.tx, *p))
    }

    /// Bytes of the image.
    pub fn image_len(&self) -> usize {
        self.blocks().map(Block::bytes).sum()
    }

    /// True if every assigned PDO exists and none twice.
    pub fn valid(&self) -> bool {
        let pdos = self.pdos();
        pdos.iter().enumerate().all(|(i, p)| {
            block_of(self.tx, *p).is_some() && !pdos.get(..i).is_some_and(|b| b.contains(p))
        })
    }

    /// Reads sub `sub`.
    pub fn read(&self, sub: u8, buf: &mut [u8]) -> Result<usize, SdoAbortCode> {
        if sub == 0 {
            return put_le(buf, u32::from(self.count), 1);
        }
        let p = self
            .pdos
            .get(usize::from(sub) - 1)
            .ok_or(SdoAbortCode::SubindexDoesNotExist)?;
        put_le(buf, u32::from(*p), 2)
    }

    /// Writes sub `sub` (PREOP), as ETG.1020 has a master write an assignment: sub 0 := 0,
    /// the entries (each an existing PDO of this direction, else 0x06090030; while sub 0 is
    /// not 0: 0x08000022), then sub 0 := the count (at most `N`; a PDO twice: 0x06040043).
    pub fn write(&mut self, sub: u8, data: &[u8]) -> Result<(), SdoAbortCode> {
        match (sub, data) {
            (0, [n]) if usize::from(*n) <= N => {
                let old = self.count;
                self.count = *n;
                if !self.valid() {
                    self.count = old;
                    return Err(SdoAbortCode::ParameterIncompatible);
                }
                Ok(())
            }
            (0, [_]) => Err(SdoAbortCode::ValueRangeExceeded),
            (_, [lo, hi]) => {
                if self.count != 0 {
                    return Err(SdoAbortCode::DeviceState);
                }
                let pdo = u16::from_le_bytes([*lo, *hi]);
                if block_of(self.tx, pdo).is_none() {
                    return Err(SdoAbortCode::ValueRangeExceeded);
                }
                let slot = self
                    .pdos
                    .get_mut(usize::from(sub) - 1)
                    .ok_or(SdoAbortCode::SubindexDoesNotExist)?;
                *slot = pdo;
                Ok(())
            }
            _ => Err(SdoAbortCode::LengthMismatch),
        }
    }
}

/// The output (RxPDO) assignment.
pub type RxAssignment = Assignment<RX_ASSIGN_MAX>;
/// The input (TxPDO) assignment.
pub type TxAssignment = Assignment<TX_ASSIGN_MAX>;

/// The default assignments: every node and the status.
pub const fn default_assignments() -> (RxAssignment, TxAssignment) {
    (
        Assignment::new(RX_ASSIGN_DEFAULT, false),
        Assignment::new(TX_ASSIGN_DEFAULT, true),
    )
}

/// PREOP -> SAFEOP: the assignments whole and SM2 / SM3 as the images need them.
pub fn check(
    rx: &RxAssignment,
    tx: &TxAssignment,
    sm2: &SyncManager,
    sm3: &SyncManager,
    expect2: &SyncManagerDesc,
    expect3: &SyncManagerDesc,
) -> Result<(), AlStatusCode> {
    if !rx.valid() {
        return Err(AlStatusCode::InvalidOutputMapping);
    }
    if !tx.valid() {
        return Err(AlStatusCode::InvalidInputMapping);
    }
    if !sm_matches(sm2, expect2, rx.image_len()) {
        return Err(AlStatusCode::InvalidOutputConfiguration);
    }
    if !sm_matches(sm3, expect3, tx.image_len()) {
        return Err(AlStatusCode::InvalidInputConfiguration);
    }
    Ok(())
}

/// A process-data SM as the description places it and as long as the image (disabled or
/// empty for an empty image).
fn sm_matches(sm: &SyncManager, expect: &SyncManagerDesc, len: usize) -> bool {
    let mask = sm_control::MODE_MASK | sm_control::DIR_MASK;
    if len == 0 {
        return !sm.enabled() || sm.length == 0;
    }
    sm.enabled()
        && sm.start == expect.start
        && sm.control & mask == expect.control & mask
        && usize::from(sm.length) == len
}
