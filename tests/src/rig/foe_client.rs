//! A master's firmware update through the in-process rig: the ESM walk to BOOT on the
//! bootstrap mailbox ([`enter_boot`], [`request_state`]) and an FoE client
//! ([`FoeClient`]: a write request, DATA packets as big as the mailbox allows, BUSY
//! answered by sending the packet again, errors with their code and text; ETG.1000.6 5.8) on
//! the raw mailbox access of [`crate::rig::sdo_client::MailboxClient`].
//!
//! ethercrab 0.7.1 has no FoE and no BOOT state, so both are done here with register access,
//! as SOEM's `firm_update` does it: INIT, the SyncManagers SM0/SM1 written with the bootstrap
//! mailbox of the SII (words 0x14..0x17), BOOT, the FoE write, INIT. The packets are built and
//! parsed with coe-core's wire layer; pysoem (SOEM) over a network interface is the
//! independent master (`tests/tests/system_update_pysoem.rs`).

use crate::rig::sdo_client::MailboxClient;
use coe_core::device::MemoryWindow;
use coe_core::wire::{Foe, FoeErrorCode, FoeRepr, Mailbox, MailboxType};
use ethercrab::SubDeviceRef;

/// Mailbox type FoE (mailbox header byte 5, bits 3..0).
pub const MAILBOX_TYPE_FOE: u8 = 0x04;

/// SyncManager control bytes of the mailboxes: mailbox mode, master writes / reads, PDI IRQ.
const SM0_CONTROL: u8 = 0x26;
const SM1_CONTROL: u8 = 0x22;

/// Why an FoE transfer failed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum FoeFailure {
    /// The slave answered with an FoE error.
    Refused {
        /// Its code.
        code: FoeErrorCode,
        /// Its text.
        text: String,
        /// The packet it answered (0: the request).
        packet: u32,
    },
    /// Anything else: no answer, a mailbox error, an answer that fits no FoE rule.
    Protocol(String),
}

impl From<String> for FoeFailure {
    fn from(s: String) -> Self {
        Self::Protocol(s)
    }
}

/// An FoE answer, owned.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Answer {
    Ack(u32),
    Busy,
    Error(FoeErrorCode, String),
}

/// Writes AL control and waits for AL status to show `state`; an error flag ends the wait
/// with the AL status code.
pub async fn request_state<S>(sd: &SubDeviceRef<'_, S>, state: u16) -> Result<(), String> {
    sd.register_write(0x0120u16, state)
        .await
        .map_err(|e| format!("AL control: {e:?}"))?;
    for _ in 0..5000 {
        let status: u16 = sd
            .register_read(0x0130u16)
            .await
            .map_err(|e| format!("AL status: {e:?}"))?;
        if status & 0x0F == state && status & 0x10 == 0 {
            return Ok(());
        }
        if status & 0x10 != 0 {
            let code: u16 = sd
                .register_read(0x0134u16)
                .await
                .map_err(|e| format!("AL status code: {e:?}"))?;
            return Err(format!(
                "AL state {state:#x} refused: AL status {status:#06x}, code {code:#06x}"
            ));
        }
    }
    Err(format!("AL state {state:#x} not reached"))
}

/// Configures the mailbox SyncManagers SM0 (`out`: master -> slave) and SM1 (`inp`), as a
/// master does in INIT before PRE-OP (standard mailbox) or BOOT (bootstrap mailbox).
pub async fn configure_mailbox<S>(
    sd: &SubDeviceRef<'_, S>,
    out: MemoryWindow,
    inp: MemoryWindow,
) -> Result<(), String> {
    for (n, window, control) in [(0u16, out, SM0_CONTROL), (1, inp, SM1_CONTROL)] {
        let mut regs = [0u8; 8];
        // The ESC takes a new start, length and control only while the SyncManager is
        // deactivated (ESC-II 0x0806 bit 0).
        sd.register_write(0x0800 + 8 * n, regs)
            .await
            .map_err(|e| format!("SM{n}: {e:?}"))?;
        regs[0..2].copy_from_slice(&window.start.to_le_bytes());
        regs[2..4].copy_from_slice(&window.len.to_le_bytes());
        regs[4] = control;
        regs[6] = 0x01;
        sd.register_write(0x0800 + 8 * n, regs)
            .await
            .map_err(|e| format!("SM{n}: {e:?}"))?;
    }
    Ok(())
}

/// The walk of SOEM's `firm_update` up to BOOT: INIT, SM0/SM1 on the bootstrap mailbox
/// (`out`: master -> slave, `inp`: slave -> master), BOOT.
pub async fn enter_boot<S>(
    sd: &SubDeviceRef<'_, S>,
    out: MemoryWindow,
    inp: MemoryWindow,
) -> Result<(), String> {
    request_state(sd, 0x01).await?;
    configure_mailbox(sd, out, inp).await?;
    request_state(sd, 0x03).await
}

/// An FoE client on the mailbox SyncManagers of one SubDevice; `MBX` is the mailbox size in
/// bytes (both directions).
pub struct FoeClient<const MBX: usize> {
    mailbox: MailboxClient<MBX>,
    /// BUSY answers seen (each made the client send its packet again).
    pub busy_answers: u32,
}

impl<const MBX: usize> FoeClient<MBX> {
    /// A client writing requests at `out_start` (SM0) and reading answers at `in_start` (SM1).
    pub fn new(out_start: u16, in_start: u16) -> Self {
        Self {
            mailbox: MailboxClient::new(out_start, in_start, 1),
            busy_answers: 0,
        }
    }

    /// Bytes of file data in a full DATA packet.
    pub const fn data_room() -> usize {
        MBX - 12
    }

    /// Sends one FoE packet and reads the answer.
    async fn exchange<S>(
        &mut self,
        sd: &SubDeviceRef<'_, S>,
        packet: FoeRepr<'_>,
    ) -> Result<Answer, String> {
        let mut bytes = vec![0u8; packet.buffer_len()];
        packet
            .emit(&mut Foe::new_unchecked(&mut bytes[..]))
            .map_err(|e| format!("{e}"))?;
        if !self.mailbox.send(sd, MAILBOX_TYPE_FOE, &bytes).await? {
            return Err("the write mailbox is full".into());
        }
        let frame = self.mailbox.read(sd).await?;
        let view = Mailbox::new_checked(&frame[..]).map_err(|e| format!("answer: {e}"))?;
        match view.mailbox_type() {
            MailboxType::Foe => {}
            MailboxType::Error => {
                return Err(format!("mailbox error reply {:02x?}", view.payload()));
            }
            other => return Err(format!("answer of mailbox type {other:?}")),
        }
        let repr = FoeRepr::parse(&Foe::new_unchecked(view.payload()))
            .map_err(|e| format!("FoE answer: {e}"))?;
        Ok(match repr {
            FoeRepr::Ack { packet_number } => Answer::Ack(packet_number),
            FoeRepr::Busy { .. } => Answer::Busy,
            FoeRepr::Error { code, text } => {
                Answer::Error(code, String::from_utf8_lossy(text).into_owned())
            }
            other => return Err(format!("a slave never sends {other:?}")),
        })
    }

    /// Writes `data` as file `name`: a write request, then DATA packets as big as the
    /// mailbox allows, the last one shorter (empty if the file fills the packets).
    pub async fn write<S>(
        &mut self,
        sd: &SubDeviceRef<'_, S>,
        name: &str,
        password: u32,
        data: &[u8],
    ) -> Result<(), FoeFailure> {
        let request = FoeRepr::WriteRequest {
            password,
            file_name: name.as_bytes(),
        };
        match self.exchange(sd, request).await? {
            Answer::Ack(0) => {}
            Answer::Error(code, text) => {
                return Err(FoeFailure::Refused {
                    code,
                    text,
                    packet: 0,
                })
            }
            other => return Err(format!("{other:?} to the write request").into()),
        }
        let room = Self::data_room();
        let mut chunks: Vec<&[u8]> = data.chunks(room).collect();
        if data.len() % room == 0 {
            chunks.push(&[]);
        }
        for (i, chunk) in chunks.iter().enumerate() {
            let number = i as u32 + 1;
            loop {
                let packet = FoeRepr::Data {
                    packet_number: number,
                    data: chunk,
                };
                match self.exchange(sd, packet).await? {
                    Answer::Ack(n) if n == number => break,
                    Answer::Busy => self.busy_answers += 1,
                    Answer::Error(code, text) => {
                        return Err(FoeFailure::Refused {
                            code,
                            text,
                            packet: number,
                        })
                    }
                    other => return Err(format!("{other:?} to DATA {number}").into()),
                }
            }
        }
        Ok(())
    }
}
