//! The application's view of the ET1100: raw PDI access plus the few registers it needs
//! (ESC datasheet section II; hardware-facts sections 1.3-1.5).
//!
//! [`EscPort`] is the seam between the slave application and the `et1100` driver: the
//! driver's `Et1100<P: Pdi>` implements it on the board and on the virtual board, a register
//! file implements it in the host tests. Every access returns the AL event bits the ESC
//! shifts out during the address phase (0x0220..0x0222), as the SPI PDI does; there is no
//! hidden state.

mod driver;
#[cfg(any(test, feature = "fake-esc"))]
pub mod fake;

/// Register addresses used by the application.
pub mod reg {
    /// AL control (u16): bits 3:0 requested state, b4 error acknowledge, b5 ID request.
    pub const AL_CONTROL: u16 = 0x0120;
    /// AL status (u16): bits 3:0 state, b4 error, b5 ID loaded.
    pub const AL_STATUS: u16 = 0x0130;
    /// AL status code (u16).
    pub const AL_STATUS_CODE: u16 = 0x0134;
    /// AL event mask (u32).
    pub const AL_EVENT_MASK: u16 = 0x0204;
    /// AL event request (u32).
    pub const AL_EVENT: u16 = 0x0220;
    /// Process-data watchdog status (u16): b0 1 = OK, 0 = expired.
    pub const WD_STATUS_PD: u16 = 0x0440;
    /// First SyncManager (8 bytes each).
    pub const SM_BASE: u16 = 0x0800;
    /// DC activation (u8).
    pub const DC_ACTIVATION: u16 = 0x0981;
    /// SYNC0 cycle time (u32, ns).
    pub const DC_SYNC0_CYCLE: u16 = 0x09A0;
}

/// AL event request bits (0x0220).
pub mod event {
    /// AL control written.
    pub const AL_CONTROL: u32 = 1 << 0;
    /// SYNC0 (only if mapped with 0x0151 b3).
    pub const SYNC0: u32 = 1 << 2;
    /// SyncManager activation register changed.
    pub const SM_ACTIVATION: u32 = 1 << 4;
    /// Process-data watchdog expired.
    pub const WATCHDOG: u32 = 1 << 6;

    /// The interrupt bit of SyncManager `n`.
    pub const fn sm(n: u8) -> u32 {
        1 << (8 + n as u32)
    }
}

/// SyncManager control byte (+4) fields.
pub use coe_core::device::sm_control;

/// One SyncManager's 8 register bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SmConfig {
    /// Physical start address.
    pub start: u16,
    /// Length in bytes.
    pub len: u16,
    /// Control byte (mode, direction, IRQ, watchdog).
    pub control: u8,
    /// Status byte (b3 mailbox full).
    pub status: u8,
    /// Activate byte (b0 enable, b1 repeat request).
    pub activate: u8,
    /// PDI control byte (b0 deactivate, b1 repeat acknowledge).
    pub pdi_control: u8,
}

impl SmConfig {
    /// PDI control b0: the PDI side deactivates the SyncManager (its buffer is emptied).
    pub const PDI_DEACTIVATE: u8 = 0x01;
    /// Activate b1 (repeat request, by the master) and PDI control b1 (repeat
    /// acknowledge, by the slave).
    pub const REPEAT: u8 = 0x02;
    /// Status b3: mailbox full.
    pub const STATUS_MAILBOX_FULL: u8 = 0x08;

    /// Decodes the 8 register bytes.
    pub const fn from_bytes(b: [u8; 8]) -> Self {
        Self {
            start: u16::from_le_bytes([b[0], b[1]]),
            len: u16::from_le_bytes([b[2], b[3]]),
            control: b[4],
            status: b[5],
            activate: b[6],
            pdi_control: b[7],
        }
    }

    /// The register bytes.
    pub const fn to_bytes(&self) -> [u8; 8] {
        let s = self.start.to_le_bytes();
        let l = self.len.to_le_bytes();
        [
            s[0],
            s[1],
            l[0],
            l[1],
            self.control,
            self.status,
            self.activate,
            self.pdi_control,
        ]
    }

    /// Activate b0.
    pub const fn enabled(&self) -> bool {
        self.activate & 0x01 != 0
    }

    /// Status b3: mailbox full.
    pub const fn mailbox_full(&self) -> bool {
        self.status & Self::STATUS_MAILBOX_FULL != 0
    }

    /// Activate b1: repeat request (toggles).
    pub const fn repeat_request(&self) -> bool {
        self.activate & Self::REPEAT != 0
    }

    /// PDI control b1: repeat acknowledge.
    pub const fn repeat_ack(&self) -> bool {
        self.pdi_control & Self::REPEAT != 0
    }

    /// Control bits 1:0 = 00.
    pub const fn three_buffer(&self) -> bool {
        self.control & sm_control::MODE_MASK == sm_control::MODE_BUFFERED
    }
}

/// What the application expects of a SyncManager (from the device description).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SmExpect {
    /// Start address.
    pub start: u16,
    /// Length (mailboxes; the process-data lengths follow the PDO configuration).
    pub len: u16,
    /// Control byte; compared on the mode and direction bits (and for mailboxes the whole
    /// byte except the ECAT IRQ bit 4, which masters choose freely).
    pub control: u8,
}

/// Raw access to the ESC from the PDI side.
pub trait EscPort {
    /// The bus error.
    type Error: core::fmt::Debug;

    /// Reads `buf.len()` bytes at `addr`; returns the AL event bits of the access.
    fn read(&mut self, addr: u16, buf: &mut [u8]) -> Result<u32, Self::Error>;

    /// Writes `data` at `addr`; returns the AL event bits of the access.
    fn write(&mut self, addr: u16, data: &[u8]) -> Result<u32, Self::Error>;

    /// Reads the AL event bits alone (a NOP access); at least bits 0..15 (AL control .. SM7),
    /// the application uses no others.
    fn events(&mut self) -> Result<u32, Self::Error> {
        // Without a NOP access: the low half of 0x0220 is all the application needs.
        let mut b = [0u8; 2];
        self.read(reg::AL_EVENT, &mut b)?;
        Ok(u32::from(u16::from_le_bytes(b)))
    }
}

/// Typed helpers over an [`EscPort`].
pub(crate) trait EscExt: EscPort {
    fn read_u8(&mut self, addr: u16) -> Result<u8, Self::Error> {
        let mut b = [0u8; 1];
        self.read(addr, &mut b)?;
        Ok(b[0])
    }

    fn read_u16(&mut self, addr: u16) -> Result<u16, Self::Error> {
        let mut b = [0u8; 2];
        self.read(addr, &mut b)?;
        Ok(u16::from_le_bytes(b))
    }

    fn read_u32(&mut self, addr: u16) -> Result<u32, Self::Error> {
        let mut b = [0u8; 4];
        self.read(addr, &mut b)?;
        Ok(u32::from_le_bytes(b))
    }

    fn sm(&mut self, n: u8) -> Result<SmConfig, Self::Error> {
        let mut b = [0u8; 8];
        self.read(reg::SM_BASE + 8 * u16::from(n), &mut b)?;
        Ok(SmConfig::from_bytes(b))
    }

    fn set_sm_pdi_control(&mut self, n: u8, value: u8) -> Result<(), Self::Error> {
        self.write(reg::SM_BASE + 8 * u16::from(n) + 7, &[value])?;
        Ok(())
    }

    /// AL status code first, then AL status, so a master that sees the error flag finds
    /// the code already there.
    fn write_al_status(&mut self, status: u16, code: u16) -> Result<(), Self::Error> {
        self.write(reg::AL_STATUS_CODE, &code.to_le_bytes())?;
        self.write(reg::AL_STATUS, &status.to_le_bytes())?;
        Ok(())
    }
}

impl<T: EscPort + ?Sized> EscExt for T {}
