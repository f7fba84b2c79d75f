//! The two read-after-conversion interfaces: without and with the busy indicator.

use crate::types::NoPin;
use crate::unconfirmed::{T_CONV_MAX_NS, T_CYC_MIN_NS};
use core::convert::Infallible;
use embedded_hal::delay::DelayNs;
use embedded_hal::digital::{InputPin, OutputPin};

/// Poll interval of the busy indicator, ns.
pub const BUSY_POLL_NS: u32 = 100;

/// Default bound of the wait for the busy indicator, ns (10 µs: several times the maximum
/// conversion time).
pub const DEFAULT_BUSY_TIMEOUT_NS: u32 = 10_000;

/// Read after conversion **without** busy indicator (AD7689 Rev. D p. 29).
///
/// CNV is the chip select of the [`SpiDevice`](embedded_hal::spi::SpiDevice): the end of a
/// transaction (CNV rising) starts a conversion, CNV stays high while it runs (at least
/// tCONV), and the next transaction (CNV low) puts the MSB on SDO and clocks 16 bits (32 with
/// CFG readback) while the next CFG goes in on DIN. SPI mode 0
/// ([`MODE_RAC`](crate::MODE_RAC)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Rac;

/// Read after conversion **with** busy indicator (AD7689 Rev. D pp. 27, 30).
///
/// The busy indicator needs CNV *low* at the end of the conversion, and a `SpiDevice` cannot
/// hold its chip select across a wait for a pin. So in this mode the driver drives CNV itself
/// (`CNV`, an [`OutputPin`]): after each frame it raises CNV (starting the next conversion)
/// and lowers it again at once, so CNV is low when the conversion ends and SDO goes from
/// high impedance (pulled up) to low: the busy indicator. The driver waits for it on `SDO`
/// (an [`InputPin`] on the SDO line, bounded by a timeout) or, with [`NoPin`], waits the
/// maximum conversion time (for a caller that saw the SDO falling edge as an interrupt, or
/// that has no such pin); a caller can also implement [`BusyLine`] for its own flag. Then 24
/// SCK (32 with CFG readback): the result is in bits 23..8, the extra clocks return SDO to
/// high impedance so that the next busy indicator can be generated. SPI mode 3
/// ([`MODE_BUSY`](crate::MODE_BUSY)).
///
/// The `SpiDevice` must not toggle any chip select the ADC sees: use one whose chip select is
/// a dummy pin, on a bus that no other device uses while CNV is low (the ADC would shift out
/// and take a CFG from every SCK edge).
#[derive(Debug)]
pub struct Busy<CNV, SDO = NoPin> {
    pub(crate) cnv: CNV,
    pub(crate) sdo: SDO,
}

/// Waiting for the busy indicator (SDO low) in busy-indicator mode.
///
/// Implemented for every [`InputPin`] (polled every [`BUSY_POLL_NS`] until low or until the
/// timeout) and for [`NoPin`] (waits [`T_CONV_MAX_NS`](crate::unconfirmed::T_CONV_MAX_NS)).
/// `E` is the error type of the CNV pin; an `InputPin` qualifies when its error type is the
/// same.
pub trait BusyLine<E> {
    /// Waits at most `timeout_ns` for the end of the conversion; `Ok(false)` on timeout.
    fn wait_low<D: DelayNs>(&mut self, delay: &mut D, timeout_ns: u32) -> Result<bool, E>;
}

impl<E> BusyLine<E> for NoPin {
    fn wait_low<D: DelayNs>(&mut self, delay: &mut D, _timeout_ns: u32) -> Result<bool, E> {
        delay.delay_ns(T_CONV_MAX_NS);
        Ok(true)
    }
}

impl<P: InputPin> BusyLine<P::Error> for P {
    fn wait_low<D: DelayNs>(&mut self, delay: &mut D, timeout_ns: u32) -> Result<bool, P::Error> {
        let mut waited: u32 = 0;
        loop {
            if self.is_low()? {
                return Ok(true);
            }
            if waited >= timeout_ns {
                return Ok(false);
            }
            delay.delay_ns(BUSY_POLL_NS);
            waited = waited.saturating_add(BUSY_POLL_NS);
        }
    }
}

/// The read interface of an [`Ad7689`](crate::Ad7689): [`Rac`] or [`Busy`]. Sealed.
pub trait Interface: private::Sealed {
    /// Error of the pins ([`Infallible`] for [`Rac`]).
    type PinError;
    /// Bytes of one frame, without and with CFG readback.
    #[doc(hidden)]
    fn frame_len(readback: bool) -> usize;
    /// Before the very first frame: start a conversion if the interface drives CNV.
    #[doc(hidden)]
    fn begin(&mut self) -> Result<(), Self::PinError>;
    /// After each frame: start the next conversion if the interface drives CNV.
    #[doc(hidden)]
    fn after_frame(&mut self) -> Result<(), Self::PinError>;
    /// Waits until the conversion in flight can be read; `Ok(false)` on timeout.
    #[doc(hidden)]
    fn wait_ready<D: DelayNs>(
        &mut self,
        delay: &mut D,
        timeout_ns: u32,
    ) -> Result<bool, Self::PinError>;
}

impl Interface for Rac {
    type PinError = Infallible;

    fn frame_len(readback: bool) -> usize {
        if readback {
            4
        } else {
            2
        }
    }

    fn begin(&mut self) -> Result<(), Infallible> {
        Ok(())
    }

    fn after_frame(&mut self) -> Result<(), Infallible> {
        Ok(())
    }

    /// CNV has been high since the end of the last frame, for an unknown time: wait a whole
    /// tCYC, so the conversion has ended (tCONV) and the next one, which starts at the end of
    /// the coming frame, has had its acquisition time (tACQ) whatever the frame's length.
    fn wait_ready<D: DelayNs>(
        &mut self,
        delay: &mut D,
        _timeout_ns: u32,
    ) -> Result<bool, Infallible> {
        delay.delay_ns(T_CYC_MIN_NS);
        Ok(true)
    }
}

impl<CNV, SDO> Interface for Busy<CNV, SDO>
where
    CNV: OutputPin,
    SDO: BusyLine<CNV::Error>,
{
    type PinError = CNV::Error;

    fn frame_len(readback: bool) -> usize {
        if readback {
            4
        } else {
            3
        }
    }

    fn begin(&mut self) -> Result<(), CNV::Error> {
        self.after_frame()
    }

    fn after_frame(&mut self) -> Result<(), CNV::Error> {
        self.cnv.set_high()?;
        self.cnv.set_low()
    }

    fn wait_ready<D: DelayNs>(
        &mut self,
        delay: &mut D,
        timeout_ns: u32,
    ) -> Result<bool, CNV::Error> {
        self.sdo.wait_low(delay, timeout_ns)
    }
}

mod private {
    pub trait Sealed {}
    impl Sealed for super::Rac {}
    impl<CNV, SDO> Sealed for super::Busy<CNV, SDO> {}
}
