//! Distributed clocks: SYNC activation (0x0981; ESC-II 2.16.2; hardware-facts 1.4).

/// DC activation register (0x0981).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SyncActivation(pub u8);

impl SyncActivation {
    /// b0: cyclic operation (SYNC unit) active.
    pub const fn cyclic_unit(self) -> bool {
        self.0 & 0x01 != 0
    }

    /// b1: SYNC0 generation active.
    pub const fn sync0(self) -> bool {
        self.0 & 0x02 != 0
    }

    /// b2: SYNC1 generation active.
    pub const fn sync1(self) -> bool {
        self.0 & 0x04 != 0
    }

    /// b3: auto-activation by writing the start time.
    pub const fn auto_activation(self) -> bool {
        self.0 & 0x08 != 0
    }

    /// b4: 64-bit start time extension.
    pub const fn start_time_extension(self) -> bool {
        self.0 & 0x10 != 0
    }

    /// b5: start time plausibility check.
    pub const fn plausibility_check(self) -> bool {
        self.0 & 0x20 != 0
    }

    /// b6: near future configuration.
    pub const fn near_future(self) -> bool {
        self.0 & 0x40 != 0
    }

    /// b7: SYNC debug pulse.
    pub const fn debug_pulse(self) -> bool {
        self.0 & 0x80 != 0
    }
}
