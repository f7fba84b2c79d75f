//! The bootloader's EtherCAT slave: INIT and BOOT, the bootstrap mailbox, FoE into the
//! staging area. Polled (no interrupts), on the `et1100` driver like the application, with
//! the application's mailbox link ([`crate::stacks::ethercat::mailbox::MailboxLink`]) around coe-core's
//! FoE mailbox and the staging writer as its file store.
//!
//! - AL control (read when its event bit is set): coe-core's ESM with BOOT. INIT -> BOOT
//!   checks SM0/SM1 against the bootstrap mailbox (0x0015 otherwise) and starts the mailbox
//!   there; BOOT -> INIT ends the bootloader: [`BootOutcome::reset`] (the reset installs a
//!   staged update and starts the application). INIT -> PREOP (or higher) resets into a
//!   valid application, and is refused with 0x0014 "no valid firmware" without one. Every
//!   other transition to or from BOOT is refused by the ESM (0x0011).
//! - In BOOT the mailbox is served in every round from the SyncManager registers (repeat
//!   request included): the loop has nothing else to do. No interrupt is used, so the AL
//!   event mask (which only gates the IRQ pin) is left alone.

use crate::platform::board::Board;
use crate::platform::boot::layout::BOOTSTRAP_MAILBOX_SIZE;
use crate::platform::boot::staging::StagingWriter;
use crate::stacks::ethercat::mailbox::{mailbox_sm_ok, MailboxLink, MailboxServer, Service};
use coe_core::device::MemoryWindow;
use coe_core::esm::{Esm, Transition, STATE_MASK};
use coe_core::foe::FoeMailbox;
use coe_core::sdo_server::Reply;
use coe_core::{AlState, AlStatusCode};
use core::marker::PhantomData;
use et1100::{AlEvents, AlStatus, Et1100, Pdi, PdiResult};
use lpc17xx_iap::{Iap, IapEntry};

/// The FoE mailbox of the bootstrap mailbox size.
pub type BootMailbox = FoeMailbox<BOOTSTRAP_MAILBOX_SIZE>;

/// The bootloader's mailbox server: FoE into the staging writer (its context; a concrete
/// type, so the read path the writer refuses is not in the bootloader).
pub struct BootServer<E: IapEntry> {
    foe: BootMailbox,
    iap: PhantomData<E>,
}

impl<E: IapEntry> BootServer<E> {
    /// Nothing in progress.
    pub const fn new() -> Self {
        Self {
            foe: BootMailbox::new(),
            iap: PhantomData,
        }
    }

    /// The FoE mailbox.
    pub fn foe(&self) -> &BootMailbox {
        &self.foe
    }
}

impl<E: IapEntry> Default for BootServer<E> {
    fn default() -> Self {
        Self::new()
    }
}

impl<E: IapEntry> MailboxServer for BootServer<E> {
    type Context<'a> = StagingWriter<E>;

    fn process(
        &mut self,
        files: &mut Self::Context<'_>,
        request: &[u8],
        state: AlState,
        now_ms: u32,
        reply: &mut [u8],
    ) -> Reply {
        self.foe.process(request, state, files, now_ms, reply)
    }

    fn poll(&mut self, _: &mut Self::Context<'_>, _: &mut [u8]) -> Reply {
        // FoE answers every packet at once; nothing waits.
        Reply::None
    }

    fn repeat(&self, reply: &mut [u8]) -> Reply {
        self.foe.repeat(reply)
    }

    fn has_outgoing(&self) -> bool {
        false
    }

    fn on_state_change(&mut self, files: &mut Self::Context<'_>, from: AlState, to: AlState) {
        self.foe.on_state_change(from, to, files)
    }
}

/// What the bootloader's main loop must do after a poll.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BootOutcome {
    /// Reset the CPU: the reset sequence installs a staged update and starts the
    /// application (or comes back here).
    pub reset: bool,
}

/// The mailbox SyncManagers of BOOT: the windows and the control bytes (as the standard
/// mailbox's).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Bootstrap {
    /// Master -> slave (SM0).
    pub out: MemoryWindow,
    /// Slave -> master (SM1).
    pub inp: MemoryWindow,
    /// SM0's control byte.
    pub out_control: u8,
    /// SM1's control byte.
    pub in_control: u8,
}

/// The bootloader's slave (`E`: the IAP ROM, or its model).
pub struct BootSlave<E: IapEntry> {
    esm: Esm,
    link: MailboxLink<BootServer<E>, BOOTSTRAP_MAILBOX_SIZE>,
    files: StagingWriter<E>,
    bootstrap: Bootstrap,
    application_valid: bool,
}

impl<E: IapEntry> BootSlave<E> {
    /// A slave in INIT that writes the update files `board` accepts through `iap`;
    /// `application_valid`: what the reset sequence found in the application slot.
    pub fn new(iap: Iap<E>, board: Board, bootstrap: Bootstrap, application_valid: bool) -> Self {
        Self {
            esm: Esm::new().with_bootstrap(true),
            link: MailboxLink::new(BootServer::new()),
            files: StagingWriter::new(iap, board),
            bootstrap,
            application_valid,
        }
    }

    /// The ESM state.
    pub fn state(&self) -> AlState {
        self.esm.state()
    }

    /// The ESM.
    pub fn esm(&self) -> &Esm {
        &self.esm
    }

    /// The staging writer (the file store).
    pub fn files(&self) -> &StagingWriter<E> {
        &self.files
    }

    /// The staging writer, mutable (its IAP access).
    pub fn files_mut(&mut self) -> &mut StagingWriter<E> {
        &mut self.files
    }

    /// Gives the IAP access back (a reset ends the bootloader).
    pub fn into_iap(self) -> Iap<E> {
        self.files.into_iap()
    }

    /// The mailbox link.
    pub fn mailbox(&self) -> &MailboxLink<BootServer<E>, BOOTSTRAP_MAILBOX_SIZE> {
        &self.link
    }

    /// Once the ESC's PDI works: AL status INIT without error, then a BOOT request the
    /// master wrote before the reset (the application read AL control, which clears its
    /// event, before it reset into the bootloader; a master does not write the request
    /// again). Any other AL control value waits for the master's next write.
    pub fn start<P: Pdi>(&mut self, esc: &mut Et1100<P>) -> PdiResult<BootOutcome, P> {
        self.write_status(esc)?;
        let mut out = BootOutcome::default();
        let control = esc.read_al_control()?.0;
        if AlState::from_nibble((control & STATE_MASK) as u8) == Some(AlState::Bootstrap) {
            self.al_control(esc, control, &mut out)?;
        }
        Ok(out)
    }

    /// One round of the main loop at `now_ms` (a wrapping millisecond clock, for the FoE
    /// timeout): AL control if its event bit is set (a NOP access reads them), then in BOOT
    /// the mailbox.
    pub fn poll<P: Pdi>(&mut self, esc: &mut Et1100<P>, now_ms: u32) -> PdiResult<BootOutcome, P> {
        let mut out = BootOutcome::default();
        if esc.low_events()?.contains(AlEvents::AL_CONTROL) {
            let control = esc.read_al_control()?.0;
            self.al_control(esc, control, &mut out)?;
        }
        if self.esm.state() == AlState::Bootstrap {
            let how = Service::Registers { check_repeat: true };
            let state = AlState::Bootstrap;
            self.link
                .service(esc, state, &mut self.files, now_ms, how)?;
        }
        Ok(out)
    }

    fn write_status<P: Pdi>(&mut self, esc: &mut Et1100<P>) -> PdiResult<(), P> {
        esc.write_al_status(AlStatus(self.esm.status()), self.esm.status_code_word())
    }

    fn al_control<P: Pdi>(
        &mut self,
        esc: &mut Et1100<P>,
        control: u16,
        out: &mut BootOutcome,
    ) -> PdiResult<(), P> {
        let from = self.esm.state();
        match self.esm.request(control) {
            Transition::Allowed {
                to: AlState::Bootstrap,
                ..
            } => {
                let sm0 = esc.read_sm(0)?;
                let sm1 = esc.read_sm(1)?;
                let b = self.bootstrap;
                if mailbox_sm_ok(&sm0, b.out.start, b.out.len, b.out_control)
                    && mailbox_sm_ok(&sm1, b.inp.start, b.inp.len, b.in_control)
                {
                    self.link.start(esc, sm0, sm1)?;
                    self.esm.complete(AlState::Bootstrap);
                } else {
                    self.esm
                        .fail(AlState::Init, AlStatusCode::InvalidMailboxConfigurationBoot);
                }
            }
            Transition::Allowed {
                to: AlState::Init, ..
            } => {
                self.esm.complete(AlState::Init);
                out.reset = true;
            }
            Transition::Allowed { .. } => {
                // PREOP and up are the application's.
                if self.application_valid {
                    out.reset = true;
                } else {
                    self.esm.fail(AlState::Init, AlStatusCode::NoValidFirmware);
                }
            }
            Transition::Stay | Transition::Refused(_) => {}
        }
        let to = self.esm.state();
        self.link.on_state_change(&mut self.files, from, to);
        self.write_status(esc)
    }
}

#[cfg(test)]
mod tests;
