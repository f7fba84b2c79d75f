//! SyncManager register block (0x0800 + 8n, 8 bytes; ESC-I 8, ESC-II 2.14;
//! hardware-facts 1.5).
//!
//! The control byte (+4) is also the SII's and the ESI's SyncManager "control byte"
//! (ETG.2010, ETG.2000), so its fields are defined once, with the device description, in
//! [`coe_core::device::sm_control`]; status, activate and PDI control exist only in the ESC
//! and are defined here.

use coe_core::device::sm_control;

/// SyncManager operation mode (control bits 1:0).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SmMode {
    /// 00: 3-buffer (process data).
    Buffered,
    /// 10: mailbox (1 buffer).
    Mailbox,
    /// 01 or 11: reserved.
    Reserved(u8),
}

/// SyncManager direction (control bits 3:2), seen from the master.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SmDirection {
    /// 00: ECAT reads, PDI writes (SM1 mailbox-in, SM3 inputs).
    EcatRead,
    /// 01: ECAT writes, PDI reads (SM0 mailbox-out, SM2 outputs).
    EcatWrite,
    /// 10 or 11: reserved.
    Reserved(u8),
}

/// One SyncManager's 8 register bytes, read in one access by
/// [`Et1100::read_sm`](crate::Et1100::read_sm).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SyncManager {
    /// +0: physical start address (a 3-buffer SM occupies 3 x `length`).
    pub start: u16,
    /// +2: length in bytes.
    pub length: u16,
    /// +4: control (mode, direction, IRQ enables, watchdog trigger).
    pub control: u8,
    /// +5: status (IntW, IntR, mailbox full, last buffer, buffer open).
    pub status: u8,
    /// +6: activate (enable, repeat request, latch events).
    pub activate: u8,
    /// +7: PDI control (deactivate, repeat acknowledge).
    pub pdi_control: u8,
}

impl SyncManager {
    /// Size of the register block.
    pub const SIZE: usize = 8;
    /// Offset of the status byte.
    pub const STATUS_OFFSET: u16 = 5;
    /// Status b3: mailbox full.
    pub const STATUS_MAILBOX_FULL: u8 = 0x08;
    /// Offset of the activate byte.
    pub const ACTIVATE_OFFSET: u16 = 6;
    /// Activate b0: SyncManager enabled.
    pub const ACTIVATE_ENABLE: u8 = 0x01;
    /// Activate b1: repeat request (the master toggles it).
    pub const ACTIVATE_REPEAT_REQUEST: u8 = 0x02;
    /// Offset of the PDI control byte.
    pub const PDI_CONTROL_OFFSET: u16 = 7;
    /// PDI control b0: deactivate the SyncManager.
    pub const PDI_DEACTIVATE: u8 = 0x01;
    /// PDI control b1: repeat acknowledge.
    pub const PDI_REPEAT_ACK: u8 = 0x02;

    /// Decodes the 8 little-endian register bytes.
    pub const fn from_bytes(b: [u8; 8]) -> Self {
        Self {
            start: u16::from_le_bytes([b[0], b[1]]),
            length: u16::from_le_bytes([b[2], b[3]]),
            control: b[4],
            status: b[5],
            activate: b[6],
            pdi_control: b[7],
        }
    }

    /// Encodes the 8 register bytes.
    pub const fn to_bytes(&self) -> [u8; 8] {
        let s = self.start.to_le_bytes();
        let l = self.length.to_le_bytes();
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

    /// The last byte of the (first) buffer, or `None` for length 0 or an overflow.
    pub const fn last_address(&self) -> Option<u16> {
        if self.length == 0 {
            return None;
        }
        self.start.checked_add(self.length - 1)
    }

    /// Control bits 1:0.
    pub const fn mode(&self) -> SmMode {
        match self.control & sm_control::MODE_MASK {
            sm_control::MODE_BUFFERED => SmMode::Buffered,
            sm_control::MODE_MAILBOX => SmMode::Mailbox,
            other => SmMode::Reserved(other),
        }
    }

    /// Control bits 3:2.
    pub const fn direction(&self) -> SmDirection {
        match self.control & sm_control::DIR_MASK {
            sm_control::DIR_ECAT_READ => SmDirection::EcatRead,
            sm_control::DIR_ECAT_WRITE => SmDirection::EcatWrite,
            other => SmDirection::Reserved(other >> 2),
        }
    }

    /// Control b4: interrupt in the ECAT event request register.
    pub const fn ecat_irq(&self) -> bool {
        self.control & sm_control::ECAT_IRQ != 0
    }

    /// Control b5: interrupt in the AL event request register.
    pub const fn pdi_irq(&self) -> bool {
        self.control & sm_control::PDI_IRQ != 0
    }

    /// Control b6: watchdog trigger enabled.
    pub const fn watchdog_trigger(&self) -> bool {
        self.control & sm_control::WATCHDOG != 0
    }

    /// Status b0: interrupt write (a buffer was written).
    pub const fn write_event(&self) -> bool {
        self.status & 0x01 != 0
    }

    /// Status b1: interrupt read (a buffer was read).
    pub const fn read_event(&self) -> bool {
        self.status & 0x02 != 0
    }

    /// Status b3: mailbox full.
    pub const fn mailbox_full(&self) -> bool {
        self.status & Self::STATUS_MAILBOX_FULL != 0
    }

    /// Status bits 5:4: last written buffer in 3-buffer mode (0..2; 3 = none written).
    pub const fn last_buffer(&self) -> u8 {
        (self.status >> 4) & 0x03
    }

    /// Status b6: read buffer in use (opened).
    pub const fn read_buffer_open(&self) -> bool {
        self.status & 0x40 != 0
    }

    /// Status b7: write buffer in use (opened).
    pub const fn write_buffer_open(&self) -> bool {
        self.status & 0x80 != 0
    }

    /// Activate b0: SyncManager enabled by the master.
    pub const fn enabled(&self) -> bool {
        self.activate & Self::ACTIVATE_ENABLE != 0
    }

    /// Activate b1: repeat request (toggles on each request).
    pub const fn repeat_request(&self) -> bool {
        self.activate & Self::ACTIVATE_REPEAT_REQUEST != 0
    }

    /// Activate b6: latch event ECAT.
    pub const fn latch_ecat(&self) -> bool {
        self.activate & 0x40 != 0
    }

    /// Activate b7: latch event PDI.
    pub const fn latch_pdi(&self) -> bool {
        self.activate & 0x80 != 0
    }

    /// PDI control b0: deactivated by the PDI.
    pub const fn deactivated(&self) -> bool {
        self.pdi_control & Self::PDI_DEACTIVATE != 0
    }

    /// PDI control b1: repeat acknowledge.
    pub const fn repeat_ack(&self) -> bool {
        self.pdi_control & Self::PDI_REPEAT_ACK != 0
    }

    /// A mailbox repeat is pending: activate b1 differs from PDI control b1 (ESC-I 8.6).
    pub const fn repeat_requested(&self) -> bool {
        self.repeat_request() != self.repeat_ack()
    }

    /// The PDI control byte that acknowledges the pending repeat: b1 copied from activate b1,
    /// b0 (deactivate) kept, reserved bits 0.
    pub const fn repeat_ack_value(&self) -> u8 {
        (self.pdi_control & Self::PDI_DEACTIVATE) | self.requested_repeat_ack()
    }

    /// Activate b1 moved to PDI control b1: the acknowledge that matches the master's
    /// current repeat request (the other PDI control bits 0).
    pub const fn requested_repeat_ack(&self) -> u8 {
        if self.repeat_request() {
            Self::PDI_REPEAT_ACK
        } else {
            0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decode_encode() {
        let b = [0x00, 0x10, 0x80, 0x00, 0x26, 0x08, 0x03, 0x00];
        let sm = SyncManager::from_bytes(b);
        assert_eq!(sm.start, 0x1000);
        assert_eq!(sm.length, 0x80);
        assert_eq!(sm.mode(), SmMode::Mailbox);
        assert_eq!(sm.direction(), SmDirection::EcatWrite);
        assert!(sm.pdi_irq() && !sm.ecat_irq() && !sm.watchdog_trigger());
        assert!(sm.mailbox_full() && sm.enabled() && sm.repeat_requested());
        assert_eq!(sm.repeat_ack_value(), 0x02);
        assert_eq!(sm.last_address(), Some(0x107F));
        assert_eq!(sm.to_bytes(), b);
    }

    #[test]
    fn edge_cases() {
        let sm = SyncManager {
            start: 0xFFF0,
            length: 0x20,
            control: 0x03,
            ..Default::default()
        };
        assert_eq!(sm.last_address(), None);
        assert_eq!(sm.mode(), SmMode::Reserved(3));
        let sm = SyncManager {
            control: 0x0E,
            ..Default::default()
        };
        assert_eq!(sm.direction(), SmDirection::Reserved(3));
        assert_eq!(SyncManager::default().last_address(), None);
    }
}
