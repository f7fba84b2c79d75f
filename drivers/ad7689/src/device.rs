//! The driver.

use crate::command::Command;
use crate::config::Config;
use crate::interface::{Busy, BusyLine, Interface, Rac, DEFAULT_BUSY_TIMEOUT_NS};
use crate::pipeline::Pipeline;
use crate::types::{Channel, Error, Sample};
use embedded_hal::delay::DelayNs;
use embedded_hal::digital::OutputPin;
use embedded_hal::spi::{Operation, SpiDevice};

/// AD7689 driver (also fits the AD7682, 4 channels: use channels 0..=3).
///
/// - `SPI`: the [`SpiDevice`]. In [`Rac`] mode its chip select is CNV.
/// - `IFACE`: [`Rac`] (read after conversion, no busy indicator) or [`Busy`] (read after
///   conversion with busy indicator; the driver drives CNV).
///
/// Each frame (one SPI transaction, one CNV-low period) returns the result of the
/// conversion that started when the previous frame ended, tagged with what it measured, as
/// tracked through the two-conversion CFG pipeline; `None` while that is unknown (after
/// power-up or an error, until a CFG written by the driver has come through).
#[derive(Debug)]
pub struct Ad7689<SPI, IFACE = Rac> {
    spi: SPI,
    iface: IFACE,
    pipe: Pipeline,
    busy_timeout_ns: u32,
}

impl<SPI: SpiDevice> Ad7689<SPI, Rac> {
    /// Read after conversion without busy indicator; CNV is the chip select of `spi`
    /// (SPI mode [`MODE_RAC`](crate::MODE_RAC)). Sends nothing.
    pub const fn new(spi: SPI) -> Self {
        Self {
            spi,
            iface: Rac,
            pipe: Pipeline::new(),
            busy_timeout_ns: DEFAULT_BUSY_TIMEOUT_NS,
        }
    }

    /// Destroys the driver and gives the SPI device back.
    pub fn destroy(self) -> SPI {
        self.spi
    }
}

impl<SPI, CNV, SDO> Ad7689<SPI, Busy<CNV, SDO>>
where
    SPI: SpiDevice,
    CNV: OutputPin,
    SDO: BusyLine<CNV::Error>,
{
    /// Read after conversion with busy indicator (SPI mode [`MODE_BUSY`](crate::MODE_BUSY)):
    /// the driver drives `cnv`, and waits for the busy indicator on `sdo` (an `InputPin` on
    /// the SDO line, or [`NoPin`](crate::NoPin)). See [`Busy`] for the wiring. Touches no pin.
    pub const fn new_busy(spi: SPI, cnv: CNV, sdo: SDO) -> Self {
        Self {
            spi,
            iface: Busy { cnv, sdo },
            pipe: Pipeline::new(),
            busy_timeout_ns: DEFAULT_BUSY_TIMEOUT_NS,
        }
    }

    /// Destroys the driver and gives the SPI device, the CNV pin and the SDO pin back.
    pub fn destroy(self) -> (SPI, CNV, SDO) {
        (self.spi, self.iface.cnv, self.iface.sdo)
    }
}

impl<SPI, IFACE> Ad7689<SPI, IFACE>
where
    SPI: SpiDevice,
    IFACE: Interface,
{
    /// One frame now: reads the result in flight, writes `cfg` (or keeps the CFG with DIN low).
    /// `verify`: check the CFG readback (if on).
    fn frame(
        &mut self,
        cfg: Option<Config>,
        verify: bool,
    ) -> Result<Option<Sample>, Error<SPI::Error, IFACE::PinError>> {
        if cfg.is_some_and(|c| !c.is_valid()) {
            return Err(Error::InvalidChannel);
        }
        let reading = self.pipe.in_flight();
        let readback = reading.is_some_and(|r| r.cfg.has_readback());
        let len = IFACE::frame_len(readback);
        let mut buf = Command::new(cfg).bytes();
        let frame = buf.get_mut(..len).unwrap_or(&mut []);
        if let Err(e) = self
            .spi
            .transaction(&mut [Operation::TransferInPlace(frame)])
        {
            self.pipe.reset();
            return Err(Error::Comm(e));
        }
        if let Err(e) = self.iface.after_frame() {
            self.pipe.reset();
            return Err(Error::Pin(e));
        }
        self.pipe.frame_done(cfg);
        let Some(r) = reading else {
            return Ok(None);
        };
        if readback && verify {
            let read = u16::from_be_bytes([buf[2], buf[3]]) >> 2;
            let expected = r.cfg.bits();
            if read != expected {
                self.pipe.reset();
                return Err(Error::ReadbackMismatch { expected, read });
            }
        }
        Ok(Some(Sample {
            channel: r.channel,
            code: u16::from_be_bytes([buf[0], buf[1]]),
        }))
    }

    /// One frame now, DIN low (CFG unchanged): returns the result of the conversion that
    /// started when the previous frame ended. The caller is responsible for the timing
    /// (for example a timer that paces frames at tCYC or more, or the SDO interrupt in busy
    /// mode); see [`read_when_ready`](Ad7689::read_when_ready) for a driver-timed read.
    ///
    /// `Ok(None)`: a result whose CFG the driver does not know (power-up dummies).
    pub fn read(&mut self) -> Result<Option<Sample>, Error<SPI::Error, IFACE::PinError>> {
        self.frame(None, true)
    }

    /// One frame now that also writes `cfg`. It governs the conversion *after* the one that
    /// starts when this frame ends, so its first result comes two frames later; a CFG with SEQ
    /// = 10/11 (or a changed channel with SEQ = 01) starts the scan at IN0 then.
    /// [`Error::InvalidChannel`] (nothing sent) if the channel is above 7.
    pub fn read_and_configure(
        &mut self,
        cfg: Config,
    ) -> Result<Option<Sample>, Error<SPI::Error, IFACE::PinError>> {
        self.frame(Some(cfg), true)
    }

    /// Waits until the conversion in flight can be read:
    /// - [`Rac`]: `delay` for tCYC ([`T_CYC_MIN_NS`](crate::unconfirmed::T_CYC_MIN_NS) =
    ///   tCONV + tACQ): CNV has been high since the last frame for an unknown time; this covers
    ///   the conversion and the acquisition of the next one.
    /// - [`Busy`] with an SDO pin: polls SDO every [`BUSY_POLL_NS`](crate::BUSY_POLL_NS) until
    ///   it is low, at most the busy timeout ([`Error::Timeout`] after that, nothing sent).
    /// - [`Busy`] with [`NoPin`](crate::NoPin): `delay` for tCONV.
    pub fn wait_ready<D: DelayNs>(
        &mut self,
        delay: &mut D,
    ) -> Result<(), Error<SPI::Error, IFACE::PinError>> {
        match self.iface.wait_ready(delay, self.busy_timeout_ns) {
            Ok(true) => Ok(()),
            Ok(false) => Err(Error::Timeout),
            Err(e) => Err(Error::Pin(e)),
        }
    }

    /// [`wait_ready`](Ad7689::wait_ready), then [`read`](Ad7689::read).
    pub fn read_when_ready<D: DelayNs>(
        &mut self,
        delay: &mut D,
    ) -> Result<Option<Sample>, Error<SPI::Error, IFACE::PinError>> {
        self.wait_ready(delay)?;
        self.read()
    }

    /// [`wait_ready`](Ad7689::wait_ready), then [`read_and_configure`](Ad7689::read_and_configure).
    pub fn configure_when_ready<D: DelayNs>(
        &mut self,
        cfg: Config,
        delay: &mut D,
    ) -> Result<Option<Sample>, Error<SPI::Error, IFACE::PinError>> {
        if !cfg.is_valid() {
            return Err(Error::InvalidChannel);
        }
        self.wait_ready(delay)?;
        self.read_and_configure(cfg)
    }

    /// The power-up sequence: (busy mode: one CNV pulse to start a conversion), then three
    /// frames, each after [`wait_ready`](Ad7689::wait_ready): the first two write `cfg` (the
    /// datasheet asks for a second write when the first may fall into the power-up phase),
    /// the third reads with DIN low. All three results are discarded (the two dummy
    /// conversions and the one that may have run with the power-up CFG). The next read
    /// returns the first result under `cfg` (IN0 for a scan).
    pub fn start<D: DelayNs>(
        &mut self,
        cfg: Config,
        delay: &mut D,
    ) -> Result<(), Error<SPI::Error, IFACE::PinError>> {
        if !cfg.is_valid() {
            return Err(Error::InvalidChannel);
        }
        self.iface.begin().map_err(Error::Pin)?;
        for write in [Some(cfg), Some(cfg), None] {
            self.wait_ready(delay)?;
            // Dummies. The third may still carry the power-up CFG if the first write fell into
            // the power-up phase, so its readback is not checked.
            self.frame(write, false)?;
        }
        Ok(())
    }

    /// What the next frame will return (`None`: unknown, the read returns `Ok(None)`).
    pub fn next_channel(&self) -> Option<Channel> {
        self.pipe.in_flight().map(|f| f.channel)
    }

    /// The CFG that governs the conversion the next frame reads (`None`: unknown).
    pub fn next_config(&self) -> Option<Config> {
        self.pipe.in_flight().map(|f| f.cfg)
    }

    /// Whether the driver knows what the next frame returns.
    pub fn is_synchronized(&self) -> bool {
        self.pipe.in_flight().is_some()
    }

    /// Forgets the pipeline state (for example after the ADC was power-cycled): reads return
    /// `None` until a CFG written by the driver has come through.
    pub fn resynchronize(&mut self) {
        self.pipe.reset();
    }

    /// Bound of the wait for the busy indicator, ns (default
    /// [`DEFAULT_BUSY_TIMEOUT_NS`](crate::DEFAULT_BUSY_TIMEOUT_NS)). Used only in [`Busy`]
    /// mode with an SDO pin.
    pub fn set_busy_timeout_ns(&mut self, timeout_ns: u32) {
        self.busy_timeout_ns = timeout_ns;
    }
}
