//! ET1100 register addresses used by the model (Beckhoff ESC datasheet Section II,
//! summarised in `docs/hardware-facts.md` section 1.4).
//!
//! These are independent of the `et1100` driver crate on purpose: the model is what
//! tests the driver.

/// 0x0000 ESC type (ET1100 = 0x11).
pub const TYPE: u16 = 0x0000;
/// 0x0001 revision.
pub const REVISION: u16 = 0x0001;
/// 0x0002 build (u16).
pub const BUILD: u16 = 0x0002;
/// 0x0004 number of FMMUs.
pub const FMMU_COUNT: u16 = 0x0004;
/// 0x0005 number of SyncManagers.
pub const SM_COUNT: u16 = 0x0005;
/// 0x0006 process RAM size in KB.
pub const RAM_SIZE: u16 = 0x0006;
/// 0x0007 port descriptor.
pub const PORT_DESCRIPTOR: u16 = 0x0007;
/// 0x0008 ESC features supported (u16).
pub const FEATURES: u16 = 0x0008;
/// 0x0010 configured station address (u16).
pub const STATION_ADDRESS: u16 = 0x0010;
/// 0x0012 configured station alias (u16, from SII word 4).
pub const STATION_ALIAS: u16 = 0x0012;
/// 0x0100 DL control (u32).
pub const DL_CONTROL: u16 = 0x0100;
/// 0x0110 DL status (u16).
pub const DL_STATUS: u16 = 0x0110;
/// 0x0120 AL control (u16).
pub const AL_CONTROL: u16 = 0x0120;
/// 0x0130 AL status (u16).
pub const AL_STATUS: u16 = 0x0130;
/// 0x0134 AL status code (u16).
pub const AL_STATUS_CODE: u16 = 0x0134;
/// 0x0140 PDI control (from SII word 0 low byte).
pub const PDI_CONTROL: u16 = 0x0140;
/// 0x0141 ESC configuration (from SII word 0 high byte).
pub const ESC_CONFIG: u16 = 0x0141;
/// 0x0150 PDI configuration (SPI: mode, IRQ driver, SEL polarity; from SII word 1).
pub const PDI_CONFIG: u16 = 0x0150;
/// 0x0151 SYNC/LATCH PDI configuration (from SII word 1 high byte).
pub const SYNC_LATCH_CONFIG: u16 = 0x0151;
/// 0x0200 ECAT event mask (u16).
pub const ECAT_EVENT_MASK: u16 = 0x0200;
/// 0x0204 AL event mask (u32), reset 0x00FF_FF0F.
pub const AL_EVENT_MASK: u16 = 0x0204;
/// 0x0210 ECAT event request (u16).
pub const ECAT_EVENT_REQUEST: u16 = 0x0210;
/// 0x0220 AL event request (u32).
pub const AL_EVENT_REQUEST: u16 = 0x0220;
/// 0x030D PDI error counter.
pub const PDI_ERROR_COUNTER: u16 = 0x030D;
/// 0x030E PDI error code.
pub const PDI_ERROR_CODE: u16 = 0x030E;
/// 0x0400 watchdog divider (u16).
pub const WD_DIVIDER: u16 = 0x0400;
/// 0x0410 PDI watchdog time (u16).
pub const WD_TIME_PDI: u16 = 0x0410;
/// 0x0420 process-data watchdog time (u16).
pub const WD_TIME_PD: u16 = 0x0420;
/// 0x0440 process-data watchdog status.
pub const WD_STATUS_PD: u16 = 0x0440;
/// 0x0442 process-data watchdog counter.
pub const WD_COUNTER_PD: u16 = 0x0442;
/// 0x0443 PDI watchdog counter.
pub const WD_COUNTER_PDI: u16 = 0x0443;
/// 0x0500 EEPROM configuration (ECAT).
pub const EEPROM_CONFIG: u16 = 0x0500;
/// 0x0501 EEPROM PDI access state.
pub const EEPROM_PDI_ACCESS: u16 = 0x0501;
/// 0x0502 EEPROM control/status (u16).
pub const EEPROM_CONTROL: u16 = 0x0502;
/// 0x0504 EEPROM word address (u32).
pub const EEPROM_ADDRESS: u16 = 0x0504;
/// 0x0508 EEPROM data (8 bytes on the ET1100).
pub const EEPROM_DATA: u16 = 0x0508;
/// 0x0600 first FMMU (16 bytes each).
pub const FMMU_BASE: u16 = 0x0600;
/// 0x0800 first SyncManager (8 bytes each).
pub const SM_BASE: u16 = 0x0800;
/// 0x0900 receive time port 0 (u32), latched by a write.
pub const DC_RECEIVE_TIME_PORT0: u16 = 0x0900;
/// 0x0910 system time (u64).
pub const DC_SYSTEM_TIME: u16 = 0x0910;
/// 0x0918 receive time of the ECAT processing unit (u64).
pub const DC_RECEIVE_TIME_PU: u16 = 0x0918;
/// 0x0920 system time offset (u64).
pub const DC_SYSTEM_TIME_OFFSET: u16 = 0x0920;
/// 0x0928 system time delay (u32).
pub const DC_SYSTEM_TIME_DELAY: u16 = 0x0928;
/// 0x092C system time difference (u32, sign in bit 31).
pub const DC_SYSTEM_TIME_DIFF: u16 = 0x092C;
/// 0x0980 cyclic unit control.
pub const DC_CYCLIC_UNIT_CONTROL: u16 = 0x0980;
/// 0x0981 activation.
pub const DC_ACTIVATION: u16 = 0x0981;
/// 0x0982 pulse length of SYNC signals (u16, x10 ns).
pub const DC_PULSE_LENGTH: u16 = 0x0982;
/// 0x0984 activation status.
pub const DC_ACTIVATION_STATUS: u16 = 0x0984;
/// 0x098E SYNC0 status.
pub const DC_SYNC0_STATUS: u16 = 0x098E;
/// 0x098F SYNC1 status.
pub const DC_SYNC1_STATUS: u16 = 0x098F;
/// 0x0990 start time cyclic operation / next SYNC0 pulse (u64).
pub const DC_START_TIME: u16 = 0x0990;
/// 0x0998 next SYNC1 pulse (u64).
pub const DC_NEXT_SYNC1: u16 = 0x0998;
/// 0x09A0 SYNC0 cycle time (u32, ns).
pub const DC_SYNC0_CYCLE: u16 = 0x09A0;
/// 0x09A4 SYNC1 cycle time (u32, ns).
pub const DC_SYNC1_CYCLE: u16 = 0x09A4;
/// First byte of process RAM.
pub const RAM_START: u16 = 0x1000;
/// Size of the modelled address space (registers + 8 KB RAM).
pub const MEM_SIZE: usize = 0x3000;

/// AL event request bits (0x0220).
pub mod al_event {
    /// AL control written.
    pub const AL_CONTROL: u32 = 1 << 0;
    /// DC latch event.
    pub const DC_LATCH: u32 = 1 << 1;
    /// SYNC0 (when mapped by 0x0151 b3).
    pub const SYNC0: u32 = 1 << 2;
    /// SYNC1 (when mapped by 0x0151 b7).
    pub const SYNC1: u32 = 1 << 3;
    /// SM activation register changed.
    pub const SM_ACTIVATION: u32 = 1 << 4;
    /// EEPROM emulation command pending.
    pub const EEPROM_EMULATION: u32 = 1 << 5;
    /// Process-data watchdog expired.
    pub const WATCHDOG_PD: u32 = 1 << 6;
    /// SyncManager n interrupt.
    pub const fn sm(n: usize) -> u32 {
        1 << (8 + n)
    }
}

/// Address of SyncManager `n`'s 8-byte register block.
pub const fn sm(n: usize) -> u16 {
    SM_BASE + 8 * n as u16
}

/// Address of FMMU `n`'s 16-byte register block.
pub const fn fmmu(n: usize) -> u16 {
    FMMU_BASE + 16 * n as u16
}
