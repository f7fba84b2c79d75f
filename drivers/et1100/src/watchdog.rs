//! Watchdog registers (0x0400..0x0443; ESC-II 2.9; hardware-facts 1.4).

/// Process-data watchdog status (0x0440 b0).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum WatchdogStatus {
    /// b0 = 1: the watchdog is running or disabled.
    Active,
    /// b0 = 0: the watchdog expired.
    Expired,
}

/// Watchdog counters (0x0442 process data, 0x0443 PDI).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct WatchdogCounters {
    /// 0x0442: process-data watchdog expirations.
    pub process_data: u8,
    /// 0x0443: PDI watchdog expirations.
    pub pdi: u8,
}
