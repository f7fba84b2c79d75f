//! The analog I/O's manufacturer settings object.

/// Manufacturer settings object (RECORD): sub 1 "AI filter" UNSIGNED8 ([`AI_FILTER_LATEST`],
/// [`AI_FILTER_AVERAGE`]), sub 2 the full scale in uV (a constant).
pub const SETTINGS_INDEX: u16 = 0x2000;
/// AI filter (`SETTINGS_INDEX`:01) value: 0x6401 is the newest sample (the default).
pub const AI_FILTER_LATEST: u8 = 0;
/// AI filter value: 0x6401 is the rounded mean of the samples of the cycle.
pub const AI_FILTER_AVERAGE: u8 = 1;
