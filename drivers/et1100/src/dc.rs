//! Distributed clocks: SYNC activation (0x0981; ESC-II 2.16.2; hardware-facts 1.4).

bitflags::bitflags! {
    /// DC activation register (0x0981).
    #[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
    pub struct SyncActivation: u8 {
        /// b0: cyclic operation (SYNC unit) active.
        const CYCLIC_UNIT = 0x01;
        /// b1: SYNC0 generation active.
        const SYNC0 = 0x02;
        /// b2: SYNC1 generation active.
        const SYNC1 = 0x04;
        /// b3: auto-activation by writing the start time.
        const AUTO_ACTIVATION = 0x08;
        /// b4: 64-bit start time extension.
        const START_TIME_EXTENSION = 0x10;
        /// b5: start time plausibility check.
        const PLAUSIBILITY_CHECK = 0x20;
        /// b6: near future configuration.
        const NEAR_FUTURE = 0x40;
        /// b7: SYNC debug pulse.
        const DEBUG_PULSE = 0x80;
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for SyncActivation {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(f, "SyncActivation({=u8:#x})", self.bits())
    }
}
