//! The 14-bit configuration register CFG (AD7682/AD7689 datasheet Rev. D, Table "Configuration
//! Register Description"; AD7949 CFG table).
//!
//! ```text
//!  13   | 12 11 10 | 9 8 7 |  6 |  5 4 3 | 2 1 |  0
//!  CFG  |  INCC    |  INx  | BW |  REF   | SEQ | RB
//! ```
//!
//! The CFG is shifted in MSB first on DIN during the first 14 SCK of a frame, so the 16-bit
//! word on the bus is `CFG << 2` ([`Config::word`]).

/// Input channel configuration, INCC (bits 12:10).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum InputConfig {
    /// 00x: bipolar differential pairs, IN- referenced to VREF/2 (two's complement).
    BipolarDifferential,
    /// 010: bipolar, INx referenced to COM = VREF/2 (two's complement).
    BipolarCom,
    /// 011: the temperature sensor.
    Temperature,
    /// 10x: unipolar differential pairs, IN- referenced to a GND sense.
    UnipolarDifferential,
    /// 110: unipolar, INx referenced to COM = GND sense.
    UnipolarCom,
    /// 111: unipolar, INx referenced to GND (single-ended; this board's inputs).
    UnipolarGnd,
}

impl InputConfig {
    /// The three INCC bits (the don't-care bit of the pair modes is sent as 0).
    pub const fn bits(self) -> u16 {
        match self {
            InputConfig::BipolarDifferential => 0b000,
            InputConfig::BipolarCom => 0b010,
            InputConfig::Temperature => 0b011,
            InputConfig::UnipolarDifferential => 0b100,
            InputConfig::UnipolarCom => 0b110,
            InputConfig::UnipolarGnd => 0b111,
        }
    }

    /// Decodes three INCC bits (only the low three bits of `bits` are looked at).
    pub const fn from_bits(bits: u16) -> Self {
        match bits & 0b111 {
            0b000 | 0b001 => InputConfig::BipolarDifferential,
            0b010 => InputConfig::BipolarCom,
            0b011 => InputConfig::Temperature,
            0b100 | 0b101 => InputConfig::UnipolarDifferential,
            0b110 => InputConfig::UnipolarCom,
            _ => InputConfig::UnipolarGnd,
        }
    }

    /// Pairs of inputs (IN0/IN1, IN2/IN3, ...): CFG bit 11 = 0.
    pub const fn is_paired(self) -> bool {
        matches!(
            self,
            InputConfig::BipolarDifferential | InputConfig::UnipolarDifferential
        )
    }

    /// Results are two's complement (the bipolar modes).
    pub const fn is_bipolar(self) -> bool {
        matches!(
            self,
            InputConfig::BipolarDifferential | InputConfig::BipolarCom
        )
    }
}

/// Low-pass filter bandwidth, BW (bit 6).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Bandwidth {
    /// 0: one quarter of the full bandwidth (less noise; reduces the throughput).
    Quarter,
    /// 1: full bandwidth.
    Full,
}

/// Reference and buffer selection, REF (bits 5:3). 100 and 101 are not used.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Reference {
    /// 000: internal 2.5 V reference, temperature sensor on.
    Internal2V5,
    /// 001: internal 4.096 V reference, temperature sensor on.
    Internal4V096,
    /// 010: external reference, temperature sensor on, internal buffer off.
    ExternalTemperature,
    /// 011: external reference with internal buffer, temperature sensor on.
    ExternalBufferTemperature,
    /// 110: external reference, internal reference, buffer and temperature sensor off.
    External,
    /// 111: external reference with internal buffer, temperature sensor off.
    ExternalBuffer,
}

impl Reference {
    /// The three REF bits.
    pub const fn bits(self) -> u16 {
        match self {
            Reference::Internal2V5 => 0b000,
            Reference::Internal4V096 => 0b001,
            Reference::ExternalTemperature => 0b010,
            Reference::ExternalBufferTemperature => 0b011,
            Reference::External => 0b110,
            Reference::ExternalBuffer => 0b111,
        }
    }

    /// Decodes three REF bits; `None` for the unused codes 100 and 101.
    pub const fn from_bits(bits: u16) -> Option<Self> {
        match bits & 0b111 {
            0b000 => Some(Reference::Internal2V5),
            0b001 => Some(Reference::Internal4V096),
            0b010 => Some(Reference::ExternalTemperature),
            0b011 => Some(Reference::ExternalBufferTemperature),
            0b110 => Some(Reference::External),
            0b111 => Some(Reference::ExternalBuffer),
            _ => None,
        }
    }

    /// Whether the temperature sensor is on with this reference setting (000, 001, 010, 011).
    pub const fn temperature_sensor_on(self) -> bool {
        matches!(
            self,
            Reference::Internal2V5
                | Reference::Internal4V096
                | Reference::ExternalTemperature
                | Reference::ExternalBufferTemperature
        )
    }

    /// The reference voltage of the internal references; `None` for external ones.
    pub const fn internal_volts(self) -> Option<f32> {
        match self {
            Reference::Internal2V5 => Some(2.5),
            Reference::Internal4V096 => Some(4.096),
            _ => None,
        }
    }
}

/// Channel sequencer, SEQ (bits 2:1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Sequencer {
    /// 00: off, every conversion converts INx (or the temperature sensor).
    Off,
    /// 01: update the CFG while a scan runs; the scan goes on unless bit 11 (paired/single)
    /// or INx changes, which restarts it at IN0.
    UpdateConfig,
    /// 10: scan IN0..INx, then the temperature sensor.
    ScanWithTemperature,
    /// 11: scan IN0..INx.
    Scan,
}

impl Sequencer {
    /// The two SEQ bits.
    pub const fn bits(self) -> u16 {
        match self {
            Sequencer::Off => 0b00,
            Sequencer::UpdateConfig => 0b01,
            Sequencer::ScanWithTemperature => 0b10,
            Sequencer::Scan => 0b11,
        }
    }

    /// Decodes two SEQ bits (only the low two bits of `bits` are looked at).
    pub const fn from_bits(bits: u16) -> Self {
        match bits & 0b11 {
            0b00 => Sequencer::Off,
            0b01 => Sequencer::UpdateConfig,
            0b10 => Sequencer::ScanWithTemperature,
            _ => Sequencer::Scan,
        }
    }
}

/// The CFG register as a typed builder.
///
/// [`Config::new`] is: overwrite, unipolar referenced to GND, IN0, full bandwidth, external
/// reference (110), sequencer off, no readback (`0x3C71`). It is a starting point, not the
/// chip's power-up CFG (which is undefined until written: see the crate docs).
///
/// ```
/// use ad7689::{Config, InputConfig, Reference, Sequencer};
/// // Unipolar to GND, scan IN0..IN7, full bandwidth, internal 4.096 V, no readback.
/// let cfg = Config::new()
///     .input(InputConfig::UnipolarGnd)
///     .channel(7)
///     .reference(Reference::Internal4V096)
///     .sequencer(Sequencer::Scan);
/// assert_eq!(cfg.bits(), 0x3FCF);
/// assert_eq!(cfg.word(), 0xFF3C);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    overwrite: bool,
    input: InputConfig,
    channel: u8,
    bandwidth: Bandwidth,
    reference: Reference,
    sequencer: Sequencer,
    readback: bool,
}

impl Default for Config {
    fn default() -> Self {
        Self::new()
    }
}

impl Config {
    /// See the type docs.
    pub const fn new() -> Self {
        Self {
            overwrite: true,
            input: InputConfig::UnipolarGnd,
            channel: 0,
            bandwidth: Bandwidth::Full,
            reference: Reference::External,
            sequencer: Sequencer::Off,
            readback: false,
        }
    }

    /// Bit 13: 1 = the CFG written in this frame replaces the current one; 0 = ignored.
    pub const fn overwrite(mut self, overwrite: bool) -> Self {
        self.overwrite = overwrite;
        self
    }

    /// Bits 12:10.
    pub const fn input(mut self, input: InputConfig) -> Self {
        self.input = input;
        self
    }

    /// Bits 9:7: the channel to convert, or the last channel of a scan. Valid: 0..=7; the
    /// driver rejects a larger value with `Error::InvalidChannel` before anything is sent
    /// ([`Config::bits`] keeps only the low three bits).
    pub const fn channel(mut self, channel: u8) -> Self {
        self.channel = channel;
        self
    }

    /// Bit 6.
    pub const fn bandwidth(mut self, bandwidth: Bandwidth) -> Self {
        self.bandwidth = bandwidth;
        self
    }

    /// Bits 5:3.
    pub const fn reference(mut self, reference: Reference) -> Self {
        self.reference = reference;
        self
    }

    /// Bits 2:1.
    pub const fn sequencer(mut self, sequencer: Sequencer) -> Self {
        self.sequencer = sequencer;
        self
    }

    /// Bit 0 (inverted): `true` = read the CFG back after each result (RB = 0: 32-bit frames),
    /// `false` = no readback (RB = 1: 16-bit frames).
    pub const fn readback(mut self, readback: bool) -> Self {
        self.readback = readback;
        self
    }

    /// Whether bit 13 is set.
    pub const fn is_overwrite(&self) -> bool {
        self.overwrite
    }

    /// The input configuration.
    pub const fn input_config(&self) -> InputConfig {
        self.input
    }

    /// The channel (INx) as given to [`Config::channel`].
    pub const fn last_channel(&self) -> u8 {
        self.channel
    }

    /// The bandwidth.
    pub const fn bandwidth_setting(&self) -> Bandwidth {
        self.bandwidth
    }

    /// The reference selection.
    pub const fn reference_setting(&self) -> Reference {
        self.reference
    }

    /// The sequencer setting.
    pub const fn sequencer_setting(&self) -> Sequencer {
        self.sequencer
    }

    /// Whether CFG readback is on (RB = 0).
    pub const fn has_readback(&self) -> bool {
        self.readback
    }

    /// Whether [`Config::channel`] is in 0..=7.
    pub const fn is_valid(&self) -> bool {
        self.channel <= 7
    }

    /// The 14-bit register value.
    pub const fn bits(&self) -> u16 {
        ((self.overwrite as u16) << 13)
            | (self.input.bits() << 10)
            | (((self.channel & 0b111) as u16) << 7)
            | ((matches!(self.bandwidth, Bandwidth::Full) as u16) << 6)
            | (self.reference.bits() << 3)
            | (self.sequencer.bits() << 1)
            | (!self.readback as u16)
    }

    /// The 16-bit word sent MSB first on DIN: `bits() << 2`.
    pub const fn word(&self) -> u16 {
        self.bits() << 2
    }

    /// Decodes a 14-bit register value (bits above 13 are ignored); `None` for an unused REF
    /// code (100, 101). The don't-care INCC bit of the pair modes is not kept.
    pub const fn from_bits(bits: u16) -> Option<Self> {
        let reference = match Reference::from_bits(bits >> 3) {
            Some(r) => r,
            None => return None,
        };
        Some(Self {
            overwrite: bits & (1 << 13) != 0,
            input: InputConfig::from_bits(bits >> 10),
            channel: ((bits >> 7) & 0b111) as u8,
            bandwidth: if bits & (1 << 6) != 0 {
                Bandwidth::Full
            } else {
                Bandwidth::Quarter
            },
            reference,
            sequencer: Sequencer::from_bits(bits >> 1),
            readback: bits & 1 == 0,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hardware_facts_example_internal_4v096() {
        let cfg = Config::new()
            .input(InputConfig::UnipolarGnd)
            .channel(7)
            .bandwidth(Bandwidth::Full)
            .reference(Reference::Internal4V096)
            .sequencer(Sequencer::Scan)
            .readback(false);
        assert_eq!(cfg.bits(), 0x3FCF);
        assert_eq!(cfg.word(), 0xFF3C);
    }

    #[test]
    fn hardware_facts_example_external() {
        let cfg = Config::new()
            .channel(7)
            .reference(Reference::External)
            .sequencer(Sequencer::Scan);
        assert_eq!(cfg.bits(), 0x3FF7);
        assert_eq!(cfg.word(), 0xFFDC);
    }

    #[test]
    fn virtual_board_scan_word() {
        // The firmware's scan word (firmware::platform::adc_scan::SCAN_CONFIG): ext + buffer, IN0..IN7.
        let cfg = Config::new()
            .channel(7)
            .reference(Reference::ExternalBuffer)
            .sequencer(Sequencer::Scan);
        assert_eq!(cfg.bits(), 0x3FFF);
        assert_eq!(cfg.word(), 0xFFFC);
    }

    #[test]
    fn default_is_new() {
        assert_eq!(Config::default(), Config::new());
        assert_eq!(Config::new().bits(), 0x3C71);
    }

    #[test]
    fn each_field_alone() {
        let zero = Config::new()
            .overwrite(false)
            .input(InputConfig::BipolarDifferential)
            .channel(0)
            .bandwidth(Bandwidth::Quarter)
            .reference(Reference::Internal2V5)
            .sequencer(Sequencer::Off)
            .readback(true);
        assert_eq!(zero.bits(), 0x0000);
        assert_eq!(zero.overwrite(true).bits(), 1 << 13);
        let incc = [
            (InputConfig::BipolarDifferential, 0b000),
            (InputConfig::BipolarCom, 0b010),
            (InputConfig::Temperature, 0b011),
            (InputConfig::UnipolarDifferential, 0b100),
            (InputConfig::UnipolarCom, 0b110),
            (InputConfig::UnipolarGnd, 0b111),
        ];
        for (i, b) in incc {
            assert_eq!(zero.input(i).bits(), b << 10);
        }
        for n in 0..8u8 {
            assert_eq!(zero.channel(n).bits(), (n as u16) << 7);
        }
        assert_eq!(zero.bandwidth(Bandwidth::Full).bits(), 1 << 6);
        let refs = [
            (Reference::Internal2V5, 0b000),
            (Reference::Internal4V096, 0b001),
            (Reference::ExternalTemperature, 0b010),
            (Reference::ExternalBufferTemperature, 0b011),
            (Reference::External, 0b110),
            (Reference::ExternalBuffer, 0b111),
        ];
        for (r, b) in refs {
            assert_eq!(zero.reference(r).bits(), b << 3);
        }
        let seqs = [
            (Sequencer::Off, 0b00),
            (Sequencer::UpdateConfig, 0b01),
            (Sequencer::ScanWithTemperature, 0b10),
            (Sequencer::Scan, 0b11),
        ];
        for (s, b) in seqs {
            assert_eq!(zero.sequencer(s).bits(), b << 1);
        }
        assert_eq!(zero.readback(false).bits(), 1);
    }

    #[test]
    fn from_bits_round_trips_canonical_values() {
        for bits in 0..(1u16 << 14) {
            match Config::from_bits(bits) {
                Some(cfg) => {
                    // The pair modes' don't-care bit (10) is not kept.
                    let canonical = if bits & (1 << 11) == 0 {
                        bits & !(1 << 10)
                    } else {
                        bits
                    };
                    assert_eq!(cfg.bits(), canonical, "{bits:#06x}");
                }
                None => assert!(matches!((bits >> 3) & 0b111, 0b100 | 0b101)),
            }
        }
        // Bits above 13 are ignored.
        assert_eq!(Config::from_bits(0xFFFF).map(|c| c.bits()), Some(0x3FFF));
    }

    #[test]
    fn invalid_channel_is_flagged_and_masked() {
        let cfg = Config::new().channel(8);
        assert!(!cfg.is_valid());
        assert_eq!(cfg.last_channel(), 8);
        assert_eq!(cfg.bits() & (0b111 << 7), 0);
        assert!(Config::new().channel(7).is_valid());
    }

    #[test]
    fn helpers() {
        assert!(InputConfig::UnipolarDifferential.is_paired());
        assert!(!InputConfig::UnipolarCom.is_paired());
        assert!(InputConfig::BipolarCom.is_bipolar());
        assert!(!InputConfig::UnipolarGnd.is_bipolar());
        assert!(Reference::ExternalTemperature.temperature_sensor_on());
        assert!(!Reference::External.temperature_sensor_on());
        assert_eq!(Reference::Internal4V096.internal_volts(), Some(4.096));
        assert_eq!(Reference::ExternalBuffer.internal_volts(), None);
    }
}
