//! What the gateway tells of its nodes: the node state of 0xA000 + 16n:01 (the EL6751's
//! codes where it has one) and the ETG.1020 diagnosis history 0x10F3, whose messages name
//! the node and say what happened in words a TwinCAT user reads in the diagnosis view.
//!
//! 0x10F3 (ETG.1020 "Diagnosis History"): :01 maximum messages, :02 the subindex of the
//! newest message (0: none), :03 the newest acknowledged (written by the master), :04 new
//! messages available (newer than the acknowledged), :05 flags (kept, not acted on: the
//! gateway works in overwrite mode and sends its Emergencies whatever they say), :06.. the
//! messages, oldest overwritten when full. A message: Diag Code (UNSIGNED32), Flags
//! (UNSIGNED16: bits 0..3 type 0 info / 1 warning / 2 error, bits 8..15 the number of
//! parameters), Text ID (UNSIGNED16), time stamp (UNSIGNED64, ns of the gateway's clock),
//! then the parameters, each a UNSIGNED16 of flags (bits 12..15 the kind: 0 a data type
//! given by bits 0..11, 2 an ASCII string of bits 0..11 bytes) and the value: here the
//! node-ID (UNSIGNED8) and the message's text (ASCII), so the text is there without an ESI
//! that lists it.

use super::od::{DIAG_MESSAGES, DIAG_MESSAGE_BYTES};
use crate::stacks::entry_bytes::put;
use coe_core::canopen::master::boot::BootError;
use coe_core::canopen::master::events::LossCause;
use coe_core::canopen::master::NodePhase;
use coe_core::SdoAbortCode;

/// A node place's state (0xA000 + 16n:01).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NodeState {
    /// 0: operational, exchanging process data.
    Operational,
    /// 1: the place holds no node.
    Unused,
    /// 2: not found (no answer to the boot's first SDO, CiA 302 B).
    NotFound,
    /// 3: another device than the configured one (C, D, M, N, O).
    WrongIdentity,
    /// 5: its configuration failed or did not read back (J).
    ConfigurationFailed,
    /// 6: error control did not start (no heartbeat K, no guarding answer F) or another
    /// boot error.
    BootFailed,
    /// 8: its boot runs.
    Booting,
    /// 9: lost while operational (heartbeat, guarding, boot-up or another state).
    Lost,
    /// 10: stopped or pre-operational by an NMT command of the gateway.
    Halted,
    /// 11: the CAN master is not running (the gateway is in INIT or PREOP).
    Idle,
    /// 22: operational, but a synchronous TPDO was missing in the last CAN cycle.
    TpdoMissing,
}

impl NodeState {
    /// The state of a place from its phase and whether a TPDO went missing.
    pub fn of(phase: NodePhase, tpdo_missing: bool) -> Self {
        match phase {
            NodePhase::Unused => Self::Unused,
            NodePhase::Idle => Self::Idle,
            NodePhase::Operational if tpdo_missing => Self::TpdoMissing,
            NodePhase::Operational => Self::Operational,
            NodePhase::Halted => Self::Halted,
            NodePhase::Lost => Self::Lost,
            NodePhase::Failed(e, _) => Self::of_boot_error(e),
            NodePhase::WaitBootup(_)
            | NodePhase::Configuring
            | NodePhase::WaitHeartbeat(_)
            | NodePhase::WaitGuard(_)
            | NodePhase::WaitStart => Self::Booting,
        }
    }

    /// The state a boot error leaves.
    pub const fn of_boot_error(e: BootError) -> Self {
        match e {
            BootError::NoDeviceType => Self::NotFound,
            BootError::DeviceTypeMismatch
            | BootError::VendorIdMismatch
            | BootError::ProductCodeMismatch
            | BootError::RevisionMismatch
            | BootError::SerialNumberMismatch => Self::WrongIdentity,
            BootError::ConfigurationFailed => Self::ConfigurationFailed,
            _ => Self::BootFailed,
        }
    }

    /// The code of 0xA000 + 16n:01.
    pub const fn code(self) -> u8 {
        match self {
            Self::Operational => 0,
            Self::Unused => 1,
            Self::NotFound => 2,
            Self::WrongIdentity => 3,
            Self::ConfigurationFailed => 5,
            Self::BootFailed => 6,
            Self::Booting => 8,
            Self::Lost => 9,
            Self::Halted => 10,
            Self::Idle => 11,
            Self::TpdoMissing => 22,
        }
    }
}

/// What a diagnosis message is about; its Text ID is the gateway's own (0x4xxx: errors,
/// 0x2xxx: warnings, 0x1xxx: information).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DiagEvent {
    /// The node booted and runs.
    Booted,
    /// Its boot failed with this CiA 302-2 error.
    BootError(BootError),
    /// It was lost.
    Lost(LossCause),
    /// It is back.
    Returned,
    /// It sent this Emergency error code.
    Emergency(u16),
    /// A synchronous TPDO of it went missing.
    TpdoMissing,
    /// A TPDO of it came with a wrong length.
    TpdoLength,
    /// An event-driven TPDO of it passed its deadline.
    TpdoTimeout,
}

/// Severity of a message (Flags bits 0..3).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Severity {
    /// 0.
    Info,
    /// 1.
    Warning,
    /// 2.
    Error,
}

impl DiagEvent {
    /// The Text ID.
    pub const fn text_id(self) -> u16 {
        match self {
            Self::Booted => 0x1001,
            Self::Returned => 0x1002,
            Self::TpdoMissing => 0x2001,
            Self::TpdoLength => 0x2002,
            Self::TpdoTimeout => 0x2003,
            Self::Emergency(_) => 0x2004,
            Self::BootError(e) => 0x4100 | e.letter() as u16,
            Self::Lost(_) => 0x4001,
        }
    }

    /// The severity.
    pub const fn severity(self) -> Severity {
        match self.text_id() >> 12 {
            1 => Severity::Info,
            2 => Severity::Warning,
            _ => Severity::Error,
        }
    }

    /// The words of the message.
    pub const fn text(self) -> &'static str {
        match self {
            Self::Booted => "CAN node booted and operational",
            Self::Returned => "CAN node back and operational",
            Self::TpdoMissing => "CAN node: synchronous TPDO missing",
            Self::TpdoLength => "CAN node: TPDO of a wrong length",
            Self::TpdoTimeout => "CAN node: event TPDO past its deadline",
            Self::Emergency(_) => "CAN node sent an Emergency",
            Self::BootError(e) => e.text(),
            Self::Lost(LossCause::Heartbeat) => "CAN node lost: no heartbeat",
            Self::Lost(LossCause::Guarding) => "CAN node lost: no guarding answer",
            Self::Lost(LossCause::BootUp) => "CAN node lost: it booted again",
            Self::Lost(LossCause::State(_)) => "CAN node lost: left operational",
        }
    }
}

/// The ETG.1020 Diag Code of the gateway's own messages (manufacturer-specific, the Text ID
/// saying which; the code Beckhoff's terminals give theirs).
pub const DIAG_CODE_MANUFACTURER: u32 = 0x0000_E800;
/// The first message's subindex.
pub const FIRST_MESSAGE_SUB: u8 = 6;
/// Parameter flags: a data type follows (bits 0..11: UNSIGNED8 = 0x0005).
const PARAM_U8: u16 = 0x0005;
/// Parameter flags: an ASCII string of (bits 0..11) bytes.
const PARAM_ASCII: u16 = 0x2000;
/// Bytes a message's text may take.
const MAX_TEXT: usize = DIAG_MESSAGE_BYTES - 16 - 3 - 2;

/// One message as kept (rendered to bytes when read).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DiagMessage {
    /// What happened.
    pub event: DiagEvent,
    /// The node-ID.
    pub node: u8,
    /// When (ns).
    pub time_ns: u64,
}

impl DiagMessage {
    /// The message's bytes (ETG.1020) into `buf`; their length.
    pub fn render(&self, buf: &mut [u8]) -> Result<usize, SdoAbortCode> {
        let text = self.event.text().as_bytes();
        let text = text.get(..MAX_TEXT).unwrap_or(text);
        let len = 16 + 3 + 2 + text.len();
        let out = buf.get_mut(..len).ok_or(SdoAbortCode::OutOfMemory)?;
        let severity = match self.event.severity() {
            Severity::Info => 0u16,
            Severity::Warning => 1,
            Severity::Error => 2,
        };
        let flags = severity | 2 << 8;
        let mut at = 0;
        let mut put = |bytes: &[u8]| {
            if let Some(dst) = out.get_mut(at..at + bytes.len()) {
                dst.copy_from_slice(bytes);
            }
            at += bytes.len();
        };
        put(&DIAG_CODE_MANUFACTURER.to_le_bytes());
        put(&flags.to_le_bytes());
        put(&self.event.text_id().to_le_bytes());
        put(&self.time_ns.to_le_bytes());
        put(&PARAM_U8.to_le_bytes());
        put(&[self.node]);
        put(&(PARAM_ASCII | text.len() as u16).to_le_bytes());
        put(text);
        Ok(len)
    }
}

/// The diagnosis history (0x10F3) in overwrite mode.
#[derive(Debug, Clone)]
pub struct DiagHistory {
    messages: [Option<DiagMessage>; DIAG_MESSAGES],
    /// Slot of the next message.
    next: usize,
    /// Subindex of the newest acknowledged message (0: none).
    acknowledged: u8,
    flags: u16,
}

impl Default for DiagHistory {
    fn default() -> Self {
        Self::new()
    }
}

impl DiagHistory {
    /// Empty.
    pub const fn new() -> Self {
        Self {
            messages: [None; DIAG_MESSAGES],
            next: 0,
            acknowledged: 0,
            flags: 0,
        }
    }

    /// Adds a message (the oldest goes when full).
    pub fn push(&mut self, message: DiagMessage) {
        if let Some(slot) = self.messages.get_mut(self.next) {
            *slot = Some(message);
        }
        self.next = (self.next + 1) % DIAG_MESSAGES;
        // An acknowledged message that was just overwritten is no longer there.
        if self.acknowledged == self.newest() {
            self.acknowledged = 0;
        }
    }

    /// Subindex of the newest message (0: none).
    pub fn newest(&self) -> u8 {
        let last = (self.next + DIAG_MESSAGES - 1) % DIAG_MESSAGES;
        match self.messages.get(last) {
            Some(Some(_)) => FIRST_MESSAGE_SUB + last as u8,
            _ => 0,
        }
    }

    /// The message at subindex `sub`.
    pub fn message(&self, sub: u8) -> Option<&DiagMessage> {
        let i = usize::from(sub.checked_sub(FIRST_MESSAGE_SUB)?);
        self.messages.get(i)?.as_ref()
    }

    /// The messages, oldest first.
    pub fn iter(&self) -> impl Iterator<Item = &DiagMessage> {
        (0..DIAG_MESSAGES).filter_map(move |k| {
            self.messages
                .get((self.next + k) % DIAG_MESSAGES)
                .and_then(Option::as_ref)
        })
    }

    /// 0x10F3:04: messages newer than the acknowledged one.
    pub fn new_available(&self) -> bool {
        self.newest() != 0 && self.newest() != self.acknowledged
    }

    /// Reads sub `sub` into `buf`.
    pub fn read(&self, sub: u8, buf: &mut [u8]) -> Result<usize, SdoAbortCode> {
        let byte = match sub {
            1 => DIAG_MESSAGES as u8,
            2 => self.newest(),
            3 => self.acknowledged,
            4 => u8::from(self.new_available()),
            _ => 0,
        };
        match sub {
            1..=4 => put(buf, &[byte]),
            5 => put(buf, &self.flags.to_le_bytes()),
            _ => match self.message(sub) {
                Some(m) => m.render(buf),
                // An empty slot reads as no data.
                None if usize::from(sub) < usize::from(FIRST_MESSAGE_SUB) + DIAG_MESSAGES => Ok(0),
                None => Err(SdoAbortCode::SubindexDoesNotExist),
            },
        }
    }

    /// Writes sub `sub`: :03 acknowledges up to a message that is there (0: none), :05
    /// the flags; the rest is read-only (the SDO server refused it before).
    pub fn write(&mut self, sub: u8, data: &[u8]) -> Result<(), SdoAbortCode> {
        match (sub, data) {
            (3, [0]) => {
                self.acknowledged = 0;
                Ok(())
            }
            (3, [s]) if self.message(*s).is_some() => {
                self.acknowledged = *s;
                Ok(())
            }
            (3, [_]) => Err(SdoAbortCode::ValueRangeExceeded),
            (5, [a, b]) => {
                self.flags = u16::from_le_bytes([*a, *b]);
                Ok(())
            }
            (3 | 5, _) => Err(SdoAbortCode::LengthMismatch),
            _ => Err(SdoAbortCode::WriteOfReadOnly),
        }
    }
}
