//! The ET1100 on any [`Pdi`]: raw access and typed register helpers.

use crate::pdi::check_range;
use crate::{
    AlControl, AlEvents, AlStatus, Error, Pdi, Register, SyncActivation, SyncManager,
    WatchdogCounters, WatchdogStatus,
};

/// ESC identification (0x0000..0x0007), read in one access by [`Et1100::esc_info`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EscInfo {
    /// 0x0000: ESC type (0x11 = ET1100).
    pub kind: u8,
    /// 0x0001: revision.
    pub revision: u8,
    /// 0x0002: build.
    pub build: u16,
    /// 0x0004: number of FMMUs.
    pub fmmus: u8,
    /// 0x0005: number of SyncManagers.
    pub sync_managers: u8,
    /// 0x0006: process RAM in KiB.
    pub ram_kib: u8,
}

impl EscInfo {
    /// ESC type of the ET1100.
    pub const ET1100: u8 = 0x11;
}

bitflags::bitflags! {
    /// DL status (0x0110, u16). The port bits above b1 are kept as read.
    #[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
    pub struct DlStatus: u16 {
        /// b0: PDI operational (EEPROM loaded correctly).
        const PDI_OPERATIONAL = 0x01;
        /// b1: PDI watchdog status (1 = reloaded, 0 = expired).
        const PDI_WATCHDOG_OK = 0x02;
        /// Link and loop bits of the ports: kept as read.
        const _ = !0;
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for DlStatus {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(f, "DlStatus({=u16:#x})", self.bits())
    }
}

/// The ET1100 EtherCAT slave controller behind a [`Pdi`].
///
/// Holds nothing but the PDI. The raw accesses return the AL events of the access; the typed
/// helpers return the value and drop the events (use [`Et1100::events`] or a raw access when
/// they matter). Helpers whose read has a side effect in the ESC say so.
#[derive(Debug)]
pub struct Et1100<P> {
    pdi: P,
}

impl<P: Pdi> Et1100<P> {
    /// Wraps the PDI.
    pub fn new(pdi: P) -> Self {
        Self { pdi }
    }

    /// Gives the PDI back.
    pub fn destroy(self) -> P {
        self.pdi
    }

    /// The PDI.
    pub fn pdi_mut(&mut self) -> &mut P {
        &mut self.pdi
    }

    /// Reads `buf.len()` bytes at `addr` in one access.
    pub fn read(&mut self, addr: u16, buf: &mut [u8]) -> Result<AlEvents, Error<P::BusError>> {
        self.pdi.read(addr, buf)
    }

    /// Writes `data` at `addr` in one access.
    pub fn write(&mut self, addr: u16, data: &[u8]) -> Result<AlEvents, Error<P::BusError>> {
        self.pdi.write(addr, data)
    }

    /// The AL event bits (SPI: a NOP access).
    pub fn events(&mut self) -> Result<AlEvents, Error<P::BusError>> {
        self.pdi.events()
    }

    /// AL event bits 0..15 alone (SPI: a 2-byte NOP access); see [`Pdi::low_events`].
    pub fn low_events(&mut self) -> Result<AlEvents, Error<P::BusError>> {
        self.pdi.low_events()
    }

    fn read_array<const N: usize>(&mut self, addr: u16) -> Result<[u8; N], Error<P::BusError>> {
        let mut b = [0u8; N];
        self.pdi.read(addr, &mut b)?;
        Ok(b)
    }

    /// Reads the u8 register `reg`.
    pub fn read_u8(&mut self, reg: Register) -> Result<u8, Error<P::BusError>> {
        self.read_array::<1>(reg.addr()).map(|b| b[0])
    }

    /// Reads the little-endian u16 register `reg`.
    pub fn read_u16(&mut self, reg: Register) -> Result<u16, Error<P::BusError>> {
        self.read_array(reg.addr()).map(u16::from_le_bytes)
    }

    /// Reads the little-endian u32 register `reg`.
    pub fn read_u32(&mut self, reg: Register) -> Result<u32, Error<P::BusError>> {
        self.read_array(reg.addr()).map(u32::from_le_bytes)
    }

    /// Reads the little-endian u64 register `reg`.
    pub fn read_u64(&mut self, reg: Register) -> Result<u64, Error<P::BusError>> {
        self.read_array(reg.addr()).map(u64::from_le_bytes)
    }

    /// ESC type, revision, build, FMMU/SM count and RAM size (0x0000..0x0007, one access).
    pub fn esc_info(&mut self) -> Result<EscInfo, Error<P::BusError>> {
        let b: [u8; 8] = self.read_array(Register::Type.addr())?;
        Ok(EscInfo {
            kind: b[0],
            revision: b[1],
            build: u16::from_le_bytes([b[2], b[3]]),
            fmmus: b[4],
            sync_managers: b[5],
            ram_kib: b[6],
        })
    }

    /// Configured station address (0x0010).
    pub fn station_address(&mut self) -> Result<u16, Error<P::BusError>> {
        self.read_u16(Register::StationAddress)
    }

    /// Configured station alias (0x0012).
    pub fn station_alias(&mut self) -> Result<u16, Error<P::BusError>> {
        self.read_u16(Register::StationAlias)
    }

    /// DL status (0x0110).
    pub fn dl_status(&mut self) -> Result<DlStatus, Error<P::BusError>> {
        self.read_u16(Register::DlStatus)
            .map(DlStatus::from_bits_retain)
    }

    /// AL control (0x0120). Side effect: clears AL event bit 0 (AL control acts like a
    /// mailbox: read it after every master write).
    pub fn read_al_control(&mut self) -> Result<AlControl, Error<P::BusError>> {
        self.read_u16(Register::AlControl).map(AlControl)
    }

    /// AL status as last written (0x0130).
    pub fn read_al_status(&mut self) -> Result<AlStatus, Error<P::BusError>> {
        self.read_u16(Register::AlStatus).map(AlStatus)
    }

    /// Writes the AL status code (0x0134) and then the AL status (0x0130): **two accesses**,
    /// because 0x0132/0x0133 in between are reserved and a single 6-byte write would write
    /// them. The code goes first so that a master that sees the error flag finds the code
    /// already set.
    pub fn write_al_status(
        &mut self,
        status: AlStatus,
        code: u16,
    ) -> Result<(), Error<P::BusError>> {
        self.write(Register::AlStatusCode.addr(), &code.to_le_bytes())?;
        self.write(Register::AlStatus.addr(), &status.0.to_le_bytes())?;
        Ok(())
    }

    /// Sets the AL event mask (0x0204): which AL event bits drive SPI_IRQ.
    pub fn set_event_mask(&mut self, mask: AlEvents) -> Result<(), Error<P::BusError>> {
        self.write(Register::AlEventMask.addr(), &mask.bits().to_le_bytes())?;
        Ok(())
    }

    /// The AL event mask (0x0204).
    pub fn event_mask(&mut self) -> Result<AlEvents, Error<P::BusError>> {
        self.read_u32(Register::AlEventMask)
            .map(AlEvents::from_bits_retain)
    }

    /// Process-data watchdog status (0x0440). Side effect: clears AL event bit 6.
    pub fn watchdog_status(&mut self) -> Result<WatchdogStatus, Error<P::BusError>> {
        let v = self.read_u16(Register::WatchdogStatusProcessData)?;
        Ok(if v & 0x01 != 0 {
            WatchdogStatus::Active
        } else {
            WatchdogStatus::Expired
        })
    }

    /// Watchdog counters (0x0442/0x0443, one access).
    pub fn watchdog_counters(&mut self) -> Result<WatchdogCounters, Error<P::BusError>> {
        let b: [u8; 2] = self.read_array(Register::WatchdogCounterProcessData.addr())?;
        Ok(WatchdogCounters {
            process_data: b[0],
            pdi: b[1],
        })
    }

    /// Watchdog divider (0x0400): tick = (value + 2) x 40 ns.
    pub fn watchdog_divider(&mut self) -> Result<u16, Error<P::BusError>> {
        self.read_u16(Register::WatchdogDivider)
    }

    /// PDI watchdog time in ticks (0x0410; 0 = off).
    pub fn watchdog_time_pdi(&mut self) -> Result<u16, Error<P::BusError>> {
        self.read_u16(Register::WatchdogTimePdi)
    }

    /// Process-data watchdog time in ticks (0x0420; 0 = off).
    pub fn watchdog_time_process_data(&mut self) -> Result<u16, Error<P::BusError>> {
        self.read_u16(Register::WatchdogTimeProcessData)
    }

    fn sm_address(n: u8) -> Result<u16, Error<P::BusError>> {
        Register::sync_manager(n).ok_or(Error::InvalidIndex)
    }

    /// SyncManager `n` (0x0800 + 8n), all 8 bytes in one access. Side effect: reading the
    /// activate byte clears AL event bit 4.
    pub fn read_sm(&mut self, n: u8) -> Result<SyncManager, Error<P::BusError>> {
        let addr = Self::sm_address(n)?;
        self.read_array(addr).map(SyncManager::from_bytes)
    }

    /// SyncManagers `n` and `n + 1` (0x0800 + 8n, 16 bytes) in one access: the pair as one
    /// snapshot, with one address phase instead of two (e.g. the mailbox's SM0 and SM1).
    /// Side effect as [`read_sm`](Self::read_sm), for both.
    pub fn read_sm_pair(
        &mut self,
        n: u8,
    ) -> Result<(SyncManager, SyncManager), Error<P::BusError>> {
        let addr = Self::sm_address(n)?;
        Self::sm_address(n.checked_add(1).ok_or(Error::InvalidIndex)?)?;
        let mut b = [[0u8; 8]; 2];
        self.pdi.read(addr, b.as_flattened_mut())?;
        let [first, second] = b;
        Ok((
            SyncManager::from_bytes(first),
            SyncManager::from_bytes(second),
        ))
    }

    /// Writes SyncManager `n`'s PDI control byte (0x0807 + 8n), e.g.
    /// [`SyncManager::PDI_DEACTIVATE`].
    pub fn sm_pdi_control(&mut self, n: u8, value: u8) -> Result<(), Error<P::BusError>> {
        let addr = Self::sm_address(n)? + SyncManager::PDI_CONTROL_OFFSET;
        self.write(addr, &[value])?;
        Ok(())
    }

    /// Whether SyncManager `sm` has a mailbox repeat pending (activate b1 != PDI control b1).
    pub fn repeat_requested(&self, sm: &SyncManager) -> bool {
        sm.repeat_requested()
    }

    /// Acknowledges a repeat on SyncManager `n` whose registers were read as `sm`: copies
    /// activate b1 into PDI control b1 (keeping b0). Rewrite the last mailbox-in message
    /// first (ESC-I 8.6).
    pub fn ack_repeat(&mut self, n: u8, sm: &SyncManager) -> Result<(), Error<P::BusError>> {
        self.sm_pdi_control(n, sm.repeat_ack_value())
    }

    /// Reads the whole mailbox of `sm` into `buf[..sm.length]` in one access that ends at its
    /// last byte, which frees the mailbox. Returns the number of bytes (`sm.length`).
    pub fn read_mailbox(
        &mut self,
        sm: &SyncManager,
        buf: &mut [u8],
    ) -> Result<usize, Error<P::BusError>> {
        let len = usize::from(sm.length);
        let dst = buf.get_mut(..len).ok_or(Error::BufferTooSmall)?;
        self.read(sm.start, dst)?;
        Ok(len)
    }

    /// Writes `data` into the mailbox of `sm` and pads with zeros up to `sm.length`, so the
    /// last byte is written and the mailbox is marked full.
    ///
    /// Accesses: one for `data` (starting at the start address), then the padding in writes of
    /// up to 32 bytes, the last ending at the mailbox's last byte. Data longer than the
    /// SyncManager is refused with [`Error::DataTooLong`] before any access.
    pub fn write_mailbox(
        &mut self,
        sm: &SyncManager,
        data: &[u8],
    ) -> Result<(), Error<P::BusError>> {
        const PAD: usize = 32;
        let len = usize::from(sm.length);
        if data.len() > len {
            return Err(Error::DataTooLong);
        }
        check_range(sm.start, len)?;
        if !data.is_empty() {
            self.write(sm.start, data)?;
        }
        let zeros = [0u8; PAD];
        let mut done = data.len();
        while done < len {
            let n = (len - done).min(PAD);
            // In range: checked above.
            let addr = (usize::from(sm.start) + done) as u16;
            self.write(addr, zeros.get(..n).unwrap_or(&[]))?;
            done += n;
        }
        Ok(())
    }

    /// Reads 3-buffer process data: `buf.len()` bytes from `sm_start` (the SyncManager's start
    /// address) in one access. Read the whole SM length so the access ends with the last
    /// byte and the buffer is released.
    pub fn read_process_data(
        &mut self,
        sm_start: u16,
        buf: &mut [u8],
    ) -> Result<AlEvents, Error<P::BusError>> {
        self.read(sm_start, buf)
    }

    /// Writes 3-buffer process data: `data` at `sm_start` in one access. Write the whole SM
    /// length so the access ends with the last byte and the buffer is handed over.
    pub fn write_process_data(
        &mut self,
        sm_start: u16,
        data: &[u8],
    ) -> Result<AlEvents, Error<P::BusError>> {
        self.write(sm_start, data)
    }

    /// DC activation (0x0981).
    pub fn sync_activation(&mut self) -> Result<SyncActivation, Error<P::BusError>> {
        self.read_u8(Register::DcActivation)
            .map(SyncActivation::from_bits_retain)
    }

    /// SYNC0 cycle time in ns (0x09A0; 0 = single shot).
    pub fn sync0_cycle_ns(&mut self) -> Result<u32, Error<P::BusError>> {
        self.read_u32(Register::DcSync0CycleTime)
    }

    /// SYNC1 cycle time in ns (0x09A4; the delay after SYNC0).
    pub fn sync1_cycle_ns(&mut self) -> Result<u32, Error<P::BusError>> {
        self.read_u32(Register::DcSync1CycleTime)
    }

    /// SYNC pulse length in units of 10 ns (0x0982; 0 = acknowledge mode).
    pub fn sync_pulse_length(&mut self) -> Result<u16, Error<P::BusError>> {
        self.read_u16(Register::DcPulseLength)
    }

    /// SYNC0 status (0x098E b0). Side effect: the read acknowledges SYNC0 (clears AL event
    /// bit 2 and, in acknowledge mode, the SYNC0 signal). On a 16-bit bus that reads whole
    /// halfwords for byte reads (an STM32 FSMC) it acknowledges SYNC1 (0x098F) as well.
    pub fn sync0_status(&mut self) -> Result<bool, Error<P::BusError>> {
        self.read_u8(Register::DcSync0Status).map(|v| v & 0x01 != 0)
    }

    /// SYNC1 status (0x098F b0). Side effect: acknowledges SYNC1 (AL event bit 3); on a
    /// 16-bit bus that reads whole halfwords for byte reads, SYNC0 (0x098E) as well.
    pub fn sync1_status(&mut self) -> Result<bool, Error<P::BusError>> {
        self.read_u8(Register::DcSync1Status).map(|v| v & 0x01 != 0)
    }

    /// DC system time in ns (0x0910, u64, one access; the first byte latches the value).
    pub fn system_time(&mut self) -> Result<u64, Error<P::BusError>> {
        self.read_u64(Register::DcSystemTime)
    }
}
