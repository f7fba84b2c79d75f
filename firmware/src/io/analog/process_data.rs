//! Process data: the PDO mapping (0x1600.., 0x1A00..) and assignment (0x1C12, 0x1C13)
//! configurable in PREOP, the process image layouts built from them at PREOP -> SAFEOP, the
//! SM2/SM3 checks against them, and the per-cycle copy SM2 -> outputs, inputs -> SM3.
//!
//! The per-cycle copy has a fast path: when every mapped object is byte-aligned and one
//! the application holds in a plain variable ([`Slot`]: AI, AO, error register), the plan
//! ([`FastImage`]) is built once at PREOP -> SAFEOP and a cycle copies the values straight
//! between the image and the application; any other layout (bit fields, gaps inside a
//! byte) takes the generic bit-exact path through [`ObjectAccess`].
//!
//! Validation and bit-exact packing are coe-core's ([`coe_core::pdo`]); this module owns the
//! configuration and decides the AL status codes:
//! - an assignment or mapping that does not validate: 0x0025 invalid output mapping /
//!   0x0024 invalid input mapping;
//! - SM2 (SM3) not matching the device description (start, mode and direction bits) or
//!   its length not the size of the assigned RxPDOs (TxPDOs), or enabled/disabled against
//!   the image: 0x001D InvalidOutputConfiguration (0x001E InvalidInputConfiguration).

use super::output_blocks::{self, OutputBlocks};
use super::oversampling::{self, InputBlocks};
use super::scaling::adc_code_to_ai;
use crate::platform::board::{AI_CHANNELS, AO_CHANNELS};
use crate::stacks::entry_bytes::{channel, put};
use coe_core::device::{sm_control, SyncManagerDesc};
use coe_core::od::{ObjectAccess, ObjectDictionary};
use coe_core::pdo::{ImageLayout, PdoAssignment, PdoDirection, PdoEntry, PdoMapping};
use coe_core::{AlState, AlStatusCode, SdoAbortCode};
use et1100::SyncManager;

/// RxPDO mapping objects offered (0x1600, 0x1601); on CAN each has its RPDO communication
/// parameter (0x1400, 0x1401).
pub const RX_PDOS: usize = 2;
/// TxPDO mapping objects offered (0x1A00..0x1A02); on CAN each has its TPDO communication
/// parameter (0x1800..0x1802).
pub const TX_PDOS: usize = 3;
/// Entries per mapping object.
pub const PDO_ENTRIES: usize = 8;
/// Largest process image per direction in bytes (without the oversampling PDOs).
pub const MAX_IMAGE: usize = 32;
/// Largest input image: the plain PDOs and the oversampling ones (when built in).
pub const MAX_INPUT_IMAGE: usize = if oversampling::BUILT {
    MAX_IMAGE + oversampling::MAX_BYTES
} else {
    MAX_IMAGE
};
/// PDOs 0x1C13 can hold: the plain TxPDOs, the block status and time, the sample PDOs
/// (when built in).
pub const TX_ASSIGN: usize = if oversampling::BUILT {
    TX_PDOS + 2 + oversampling::SAMPLE_PDOS
} else {
    TX_PDOS
};
/// Largest output image: the plain PDOs and the oversampling ones (when built in).
pub const MAX_OUTPUT_IMAGE: usize = if output_blocks::BUILT {
    MAX_IMAGE + output_blocks::MAX_BYTES
} else {
    MAX_IMAGE
};
/// PDOs 0x1C12 can hold: the plain RxPDOs, the block counter, the update PDOs (when built
/// in).
pub const RX_ASSIGN: usize = if output_blocks::BUILT {
    RX_PDOS + 1 + output_blocks::UPDATE_PDOS
} else {
    RX_PDOS
};
/// Largest number of mapped objects per direction.
pub const MAX_FIELDS: usize = 16;

/// One PDO mapping object.
pub type Mapping = PdoMapping<PDO_ENTRIES>;

/// A process-data object the application holds in a plain variable.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Slot {
    /// 0x6401:n (INTEGER16), `n - 1`.
    Ai(u8),
    /// 0x6411:n (INTEGER16), `n - 1`.
    Ao(u8),
    /// 0x1001 (UNSIGNED8).
    ErrorRegister,
}

impl Slot {
    /// The slot of a mapped object of `bit_len` bits, if it has one.
    pub fn of(index: u16, subindex: u8, bit_len: u8) -> Option<Self> {
        let n = subindex.wrapping_sub(1);
        match (index, bit_len) {
            (0x6401, 16) if usize::from(n) < AI_CHANNELS => Some(Self::Ai(n)),
            (0x6411, 16) if usize::from(n) < AO_CHANNELS => Some(Self::Ao(n)),
            (0x1001, 8) if subindex == 0 => Some(Self::ErrorRegister),
            _ => None,
        }
    }

    /// Bytes in the image.
    const fn len(self) -> usize {
        match self {
            Self::ErrorRegister => 1,
            _ => 2,
        }
    }
}

/// A run of the fast-path plan: `count` objects of one kind, channels `first`,
/// `first + 1`, .. at consecutive places of the image from byte `offset` (an error
/// register is a run of its own).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Run {
    /// Byte offset of the first object in the image.
    pub offset: u8,
    /// The first object's slot.
    pub first: Slot,
    /// Objects in the run.
    pub count: u8,
}

impl Run {
    /// The run's image bytes and, for the channel kinds, its channel range.
    fn spans(&self) -> (core::ops::Range<usize>, core::ops::Range<usize>) {
        let (o, n) = (usize::from(self.offset), usize::from(self.count));
        let channels = match self.first {
            Slot::Ai(i) | Slot::Ao(i) => usize::from(i)..usize::from(i) + n,
            Slot::ErrorRegister => 0..0,
        };
        (o..o + n * self.first.len(), channels)
    }

    /// Whether `slot` at byte `offset` is the next object of this run.
    fn continued_by(&self, offset: u8, slot: Slot) -> bool {
        let next = usize::from(self.offset) + usize::from(self.count) * slot.len();
        let n = self.count;
        usize::from(offset) == next
            && match (self.first, slot) {
                (Slot::Ai(a), Slot::Ai(b)) | (Slot::Ao(a), Slot::Ao(b)) => {
                    a.checked_add(n) == Some(b)
                }
                _ => false,
            }
    }
}

/// The fast-path plan of one process image: the mapped objects as runs of consecutive
/// channels, so a cycle copies each run in one loop (the default mapping is one run per
/// direction) instead of deciding per object.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FastImage {
    runs: [Run; MAX_FIELDS],
    count: usize,
}

impl FastImage {
    /// The plan of `layout`, or `None` if an object is not byte-aligned, has no slot, or is
    /// not allowed in this direction (`allow`).
    pub fn build(layout: &ImageLayout<MAX_FIELDS>, allow: fn(Slot) -> bool) -> Option<Self> {
        let mut plan = Self {
            runs: [Run {
                offset: 0,
                first: Slot::ErrorRegister,
                count: 0,
            }; MAX_FIELDS],
            count: 0,
        };
        for field in layout.fields() {
            let slot =
                Slot::of(field.index, field.subindex, field.bit_len).filter(|s| allow(*s))?;
            let offset = u8::try_from(field.bit_offset / 8).ok()?;
            if field.bit_offset % 8 != 0 || usize::from(offset) + slot.len() > MAX_IMAGE {
                return None;
            }
            let last = plan.count.checked_sub(1).and_then(|i| plan.runs.get_mut(i));
            if let Some(run) = last.filter(|r| r.continued_by(offset, slot)) {
                run.count += 1;
                continue;
            }
            *plan.runs.get_mut(plan.count)? = Run {
                offset,
                first: slot,
                count: 1,
            };
            plan.count += 1;
        }
        Some(plan)
    }

    /// The runs of the plan, in image order.
    pub fn runs(&self) -> &[Run] {
        self.runs.get(..self.count).unwrap_or(&[])
    }
}

/// The values a [`Slot`] names, for one cycle (borrowed: packing copies each value once,
/// straight into the image).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SlotValues<'a> {
    /// Published analog-input conversion codes (the 0x6401 values are
    /// [`adc_code_to_ai`] of them).
    pub ai_codes: &'a [u16; AI_CHANNELS],
    /// Analog outputs.
    pub ao: &'a [i16; AO_CHANNELS],
    /// Error register (0x1001).
    pub error_register: u8,
}

/// The PDO configuration and the process images.
#[derive(Debug, Clone)]
pub struct ProcessData {
    rx: [Mapping; RX_PDOS],
    tx: [Mapping; TX_PDOS],
    rx_assign: PdoAssignment<RX_ASSIGN>,
    tx_assign: PdoAssignment<TX_ASSIGN>,
    defaults: (
        [Mapping; RX_PDOS],
        [Mapping; TX_PDOS],
        PdoAssignment<RX_ASSIGN>,
        PdoAssignment<TX_ASSIGN>,
    ),
    rx_layout: ImageLayout<MAX_FIELDS>,
    tx_layout: ImageLayout<MAX_FIELDS>,
    rx_fast: Option<FastImage>,
    tx_fast: Option<FastImage>,
    /// The oversampling PDOs of the TxPDO layout in effect (after the plain ones).
    tx_blocks: InputBlocks,
    /// The oversampling PDOs of the RxPDO layout in effect (after the plain ones; only in a
    /// build with output oversampling, so the others keep their layout).
    #[cfg(any(feature = "analog-io", not(target_os = "none")))]
    rx_blocks: OutputBlocks,
    /// Whether 0x1C13 takes the oversampling PDOs (a product whose dictionary has them).
    blocks_offered: bool,
    /// Whether 0x1C12 takes the output oversampling PDOs.
    #[cfg(any(feature = "analog-io", not(target_os = "none")))]
    output_blocks_offered: bool,
    outputs: [u8; MAX_OUTPUT_IMAGE],
    inputs: [u8; MAX_INPUT_IMAGE],
}

/// The mapping objects `indices` with their default `entries` (a product's default
/// configuration, built when compiling).
pub const fn mappings<const N: usize>(
    indices: [u16; N],
    entries: [&[PdoEntry]; N],
) -> [Mapping; N] {
    let mut out = [Mapping::new(0); N];
    let mut i = 0;
    while i < N {
        out[i] = Mapping::with_entries(indices[i], entries[i]);
        i += 1;
    }
    out
}

/// Bits a PDO (and an assignment) may hold.
const MAX_BITS: u32 = (MAX_IMAGE * 8) as u32;

impl ProcessData {
    /// A configuration: the mapping objects (their indices name them) and the assigned
    /// PDOs.
    pub fn new(
        rx: [Mapping; RX_PDOS],
        tx: [Mapping; TX_PDOS],
        rx_assign: &[u16],
        tx_assign: &[u16],
    ) -> Self {
        let rx_assign = PdoAssignment::with_pdos(0x1C12, rx_assign);
        let tx_assign = PdoAssignment::with_pdos(0x1C13, tx_assign);
        Self {
            rx,
            tx,
            rx_assign,
            tx_assign,
            defaults: (rx, tx, rx_assign, tx_assign),
            rx_layout: ImageLayout::new(),
            tx_layout: ImageLayout::new(),
            rx_fast: None,
            tx_fast: None,
            tx_blocks: InputBlocks::NONE,
            #[cfg(any(feature = "analog-io", not(target_os = "none")))]
            rx_blocks: OutputBlocks::NONE,
            blocks_offered: false,
            #[cfg(any(feature = "analog-io", not(target_os = "none")))]
            output_blocks_offered: false,
            outputs: [0; MAX_OUTPUT_IMAGE],
            inputs: [0; MAX_INPUT_IMAGE],
        }
    }

    /// Back to the default configuration (INIT).
    pub fn reset(&mut self) {
        let (rx, tx, ra, ta) = self.defaults;
        let blocks_offered = self.blocks();
        #[cfg(any(feature = "analog-io", not(target_os = "none")))]
        let output_blocks_offered = self.output_blocks();
        *self = Self {
            rx,
            tx,
            rx_assign: ra,
            tx_assign: ta,
            defaults: self.defaults,
            rx_layout: ImageLayout::new(),
            tx_layout: ImageLayout::new(),
            rx_fast: None,
            tx_fast: None,
            tx_blocks: InputBlocks::NONE,
            #[cfg(any(feature = "analog-io", not(target_os = "none")))]
            rx_blocks: OutputBlocks::NONE,
            blocks_offered,
            #[cfg(any(feature = "analog-io", not(target_os = "none")))]
            output_blocks_offered,
            outputs: [0; MAX_OUTPUT_IMAGE],
            inputs: [0; MAX_INPUT_IMAGE],
        };
    }

    /// Whether 0x1C13 takes the oversampling PDOs (never in a build without them).
    fn blocks(&self) -> bool {
        oversampling::BUILT && self.blocks_offered
    }

    /// The same, with the input oversampling PDOs (`super::oversampling`) offered in 0x1C13.
    pub fn with_input_blocks(mut self) -> Self {
        self.blocks_offered = oversampling::BUILT;
        self
    }

    /// Whether 0x1C12 takes the output oversampling PDOs (never in a build without them).
    #[cfg(any(feature = "analog-io", not(target_os = "none")))]
    fn output_blocks(&self) -> bool {
        self.output_blocks_offered
    }

    /// Whether 0x1C12 takes the output oversampling PDOs (never in a build without them).
    #[cfg(not(any(feature = "analog-io", not(target_os = "none"))))]
    fn output_blocks(&self) -> bool {
        false
    }

    /// The same, with the output oversampling PDOs (`super::output_blocks`) offered in
    /// 0x1C12 (a build without them ignores it).
    #[cfg(any(feature = "analog-io", not(target_os = "none")))]
    pub fn with_output_blocks(mut self) -> Self {
        self.output_blocks_offered = true;
        self
    }

    /// The same: nothing to offer in a build without output oversampling.
    #[cfg(not(any(feature = "analog-io", not(target_os = "none"))))]
    pub fn with_output_blocks(self) -> Self {
        self
    }

    /// Size in bytes of the assigned RxPDOs (SM2 length).
    pub fn output_len(&self) -> usize {
        let plain = (self.rx_assign.bit_len(&self.rx) as usize).div_ceil(8);
        if !self.output_blocks() {
            return plain;
        }
        let blocks = OutputBlocks::split(self.rx_assign.pdos()).map_or(0, |(_, b)| b.byte_len());
        plain + blocks
    }

    /// The output oversampling PDOs of the RxPDO layout in effect.
    #[cfg(any(feature = "analog-io", not(target_os = "none")))]
    pub fn output_blocks_in_effect(&self) -> &OutputBlocks {
        &self.rx_blocks
    }

    /// The output oversampling PDOs of the RxPDO layout in effect: none in this build.
    #[cfg(not(any(feature = "analog-io", not(target_os = "none"))))]
    pub fn output_blocks_in_effect(&self) -> &OutputBlocks {
        &OutputBlocks::NONE
    }

    /// Size in bytes of the assigned TxPDOs (SM3 length).
    pub fn input_len(&self) -> usize {
        let plain = (self.tx_assign.bit_len(&self.tx) as usize).div_ceil(8);
        if !self.blocks() {
            return plain;
        }
        let blocks = InputBlocks::split(self.tx_assign.pdos()).map_or(0, |(_, b)| b.byte_len());
        plain + blocks
    }

    /// Sample slots the TxPDO assignment holds now (0x8000:03).
    pub fn assigned_slots(&self) -> usize {
        InputBlocks::split(self.tx_assign.pdos()).map_or(0, |(_, b)| b.slots())
    }

    /// The oversampling PDOs of the TxPDO layout in effect.
    pub fn input_blocks(&self) -> &InputBlocks {
        &self.tx_blocks
    }

    /// True if `index:subindex` is in an assigned RxPDO.
    pub fn is_rx_mapped(&self, index: u16, subindex: u8) -> bool {
        self.rx_assign.pdos().iter().any(|pdo| {
            self.rx.iter().any(|m| {
                m.index() == *pdo
                    && m.entries()
                        .iter()
                        .any(|e| e.index == index && e.subindex == subindex)
            })
        })
    }

    /// True for the objects this module serves (0x16xx, 0x1Axx of the offered PDOs,
    /// 0x1C12, 0x1C13).
    pub fn owns(&self, index: u16) -> bool {
        index == 0x1C12
            || index == 0x1C13
            || self.rx.iter().any(|m| m.index() == index)
            || self.tx.iter().any(|m| m.index() == index)
    }

    /// SDO upload.
    pub fn read(&self, index: u16, sub: u8, buf: &mut [u8]) -> Result<usize, SdoAbortCode> {
        match index {
            0x1C12 => self.rx_assign.read_sub(sub, buf),
            0x1C13 => self.tx_assign.read_sub(sub, buf),
            _ => self
                .rx
                .iter()
                .chain(self.tx.iter())
                .find(|m| m.index() == index)
                .ok_or(SdoAbortCode::ObjectDoesNotExist)?
                .read_sub(sub, buf),
        }
    }

    /// SDO download (PREOP only: 0x08000022 otherwise; the ETG.1020 rules of
    /// [`PdoMapping::write_sub`] / [`PdoAssignment::write_sub`]).
    pub fn write(
        &mut self,
        index: u16,
        sub: u8,
        data: &[u8],
        state: AlState,
        od: &ObjectDictionary,
    ) -> Result<(), SdoAbortCode> {
        if state != AlState::PreOp {
            return Err(SdoAbortCode::DeviceState);
        }
        match index {
            0x1C12 if !self.output_blocks() => {
                self.rx_assign.write_sub(sub, data, &self.rx, MAX_BITS)
            }
            0x1C12 => {
                let rx = &self.rx;
                let plain_bits = |pdo| rx.iter().find(|m| m.index() == pdo).map(|m| m.bit_len());
                self.rx_assign.write_sub_with(
                    sub,
                    data,
                    |pdo| plain_bits(pdo).or(OutputBlocks::pdo_bits(pdo)),
                    |pdos| {
                        let (plain, _) = OutputBlocks::split(pdos)?;
                        let bits = pdos.iter().take(plain).filter_map(|p| plain_bits(*p));
                        if bits.sum::<u32>() > MAX_BITS {
                            return Err(SdoAbortCode::PdoLengthExceeded);
                        }
                        Ok(())
                    },
                    (MAX_OUTPUT_IMAGE * 8) as u32,
                )
            }
            0x1C13 if !self.blocks() => self.tx_assign.write_sub(sub, data, &self.tx, MAX_BITS),
            0x1C13 => {
                let tx = &self.tx;
                let plain_bits = |pdo| tx.iter().find(|m| m.index() == pdo).map(|m| m.bit_len());
                let offered = self.blocks_offered;
                self.tx_assign.write_sub_with(
                    sub,
                    data,
                    |pdo| plain_bits(pdo).or(InputBlocks::pdo_bits(pdo).filter(|_| offered)),
                    |pdos| {
                        let (plain, _) = InputBlocks::split(pdos)?;
                        let bits = pdos.iter().take(plain).filter_map(|p| plain_bits(*p));
                        if bits.sum::<u32>() > MAX_BITS {
                            return Err(SdoAbortCode::PdoLengthExceeded);
                        }
                        Ok(())
                    },
                    (MAX_INPUT_IMAGE * 8) as u32,
                )
            }
            _ => {
                let rx_pos = self.rx.iter().position(|m| m.index() == index);
                let tx_pos = self.tx.iter().position(|m| m.index() == index);
                let slot = match (rx_pos, tx_pos) {
                    (Some(i), _) => self.rx.get_mut(i),
                    (None, Some(i)) => self.tx.get_mut(i),
                    (None, None) => None,
                }
                .ok_or(SdoAbortCode::ObjectDoesNotExist)?;
                let old = *slot;
                slot.write_sub(sub, data, od, MAX_BITS)?;
                // A changed mapping must still fit the assignment that uses it.
                if self.rx_assign.validate(&self.rx, MAX_BITS).is_err()
                    || self.tx_assign.validate(&self.tx, MAX_BITS).is_err()
                {
                    if let Some(slot) = match (rx_pos, tx_pos) {
                        (Some(i), _) => self.rx.get_mut(i),
                        (None, Some(i)) => self.tx.get_mut(i),
                        (None, None) => None,
                    } {
                        *slot = old;
                    }
                    return Err(SdoAbortCode::PdoLengthExceeded);
                }
                Ok(())
            }
        }
    }

    /// PREOP -> SAFEOP: validates the configuration, builds the image layouts and checks SM2
    /// and SM3 against them. On error nothing changes.
    pub fn prepare(
        &mut self,
        od: &ObjectDictionary,
        sm2: &SyncManager,
        sm3: &SyncManager,
        expect2: &SyncManagerDesc,
        expect3: &SyncManagerDesc,
    ) -> Result<(), AlStatusCode> {
        let valid = |maps: &[Mapping]| maps.iter().all(|m| m.validate(od, MAX_BITS).is_ok());
        // The plain RxPDOs come first, the oversampling ones after them (`OutputBlocks`).
        let (rx_plain_n, rx_blocks) = match self.output_blocks() {
            true => OutputBlocks::split(self.rx_assign.pdos())
                .map_err(|_| AlStatusCode::InvalidOutputMapping)?,
            false => (self.rx_assign.pdos().len(), OutputBlocks::NONE),
        };
        let rx_prefix;
        let rx_plain = if self.output_blocks() {
            let pdos = self.rx_assign.pdos().get(..rx_plain_n).unwrap_or(&[]);
            rx_prefix = PdoAssignment::<RX_ASSIGN>::with_pdos(0x1C12, pdos);
            &rx_prefix
        } else {
            &self.rx_assign
        };
        if !valid(&self.rx) || rx_plain.validate(&self.rx, MAX_BITS).is_err() {
            return Err(AlStatusCode::InvalidOutputMapping);
        }
        // The plain TxPDOs come first, the oversampling ones after them (`InputBlocks`).
        let (plain, tx_blocks) = match self.blocks() {
            true => InputBlocks::split(self.tx_assign.pdos())
                .map_err(|_| AlStatusCode::InvalidInputMapping)?,
            false => (self.tx_assign.pdos().len(), InputBlocks::NONE),
        };
        let prefix;
        let tx_plain = if self.blocks() {
            let pdos = self.tx_assign.pdos().get(..plain).unwrap_or(&[]);
            prefix = PdoAssignment::<TX_ASSIGN>::with_pdos(0x1C13, pdos);
            &prefix
        } else {
            &self.tx_assign
        };
        if !valid(&self.tx) || tx_plain.validate(&self.tx, MAX_BITS).is_err() {
            return Err(AlStatusCode::InvalidInputMapping);
        }
        let rx_layout = ImageLayout::build(rx_plain, &self.rx)
            .map_err(|_| AlStatusCode::InvalidOutputMapping)?;
        let tx_layout = ImageLayout::build(tx_plain, &self.tx)
            .map_err(|_| AlStatusCode::InvalidInputMapping)?;
        if rx_layout.byte_len() > MAX_IMAGE {
            return Err(AlStatusCode::InvalidOutputMapping);
        }
        if tx_layout.byte_len() > MAX_IMAGE {
            return Err(AlStatusCode::InvalidInputMapping);
        }
        if !sm_matches(sm2, expect2, rx_layout.byte_len() + rx_blocks.byte_len()) {
            return Err(AlStatusCode::InvalidOutputConfiguration);
        }
        let mut len = tx_layout.byte_len();
        if self.blocks() {
            len += tx_blocks.byte_len();
        }
        if !sm_matches(sm3, expect3, len) {
            return Err(AlStatusCode::InvalidInputConfiguration);
        }
        self.rx_fast = FastImage::build(&rx_layout, |s| matches!(s, Slot::Ao(_)));
        self.tx_fast = FastImage::build(&tx_layout, |_| true);
        self.rx_layout = rx_layout;
        self.tx_layout = tx_layout;
        if self.blocks() {
            self.tx_blocks = tx_blocks;
        }
        #[cfg(any(feature = "analog-io", not(target_os = "none")))]
        {
            self.rx_blocks = rx_blocks;
        }
        self.inputs = [0; MAX_INPUT_IMAGE];
        Ok(())
    }

    /// The fast-path plans in effect (outputs, inputs); `None`: the generic path.
    pub fn fast_plans(&self) -> (Option<&FastImage>, Option<&FastImage>) {
        (self.rx_fast.as_ref(), self.tx_fast.as_ref())
    }

    /// The AO values of the output image: `ao` with every mapped AO replaced. The fast
    /// plan when there is one, else [`ProcessData::unpack`] through `sink`.
    pub fn unpack_ao(
        &self,
        ao: [i16; AO_CHANNELS],
        state: AlState,
    ) -> Result<[i16; AO_CHANNELS], SdoAbortCode> {
        let Some(plan) = &self.rx_fast else {
            let mut sink = RxSink { ao };
            self.unpack(&mut sink, state)?;
            return Ok(sink.ao);
        };
        let mut ao = ao;
        for run in plan.runs() {
            let (bytes, channels) = run.spans();
            if let (Some(src), Some(dst)) = (self.outputs.get(bytes), ao.get_mut(channels)) {
                for (value, b) in dst.iter_mut().zip(src.chunks_exact(2)) {
                    *value = i16::from_le_bytes([b[0], b[1]]);
                }
            }
        }
        Ok(ao)
    }

    /// The oversampling part of the input image (after the plain PDOs), to be filled
    /// before [`ProcessData::pack_values`].
    pub fn input_blocks_image_mut(&mut self) -> &mut [u8] {
        let n = self.tx_layout.byte_len().min(MAX_IMAGE);
        let end = n + self.tx_blocks.byte_len();
        self.inputs.get_mut(n..end).unwrap_or(&mut [])
    }

    /// Packs the input image from `values` (fast plan, else through the slot-by-slot packer) and
    /// returns it (SM3 content: the plain PDOs, then the oversampling part as it was filled).
    pub fn pack_values(&mut self, values: &SlotValues) -> Result<&[u8], SdoAbortCode> {
        let n = self.tx_layout.byte_len().min(MAX_IMAGE);
        let whole = if self.blocks() {
            n + self.tx_blocks.byte_len()
        } else {
            n
        };
        let Some(plan) = &self.tx_fast else {
            let mut source = TxSource {
                ai: values.ai_codes.map(adc_code_to_ai),
                ao: *values.ao,
                error_register: values.error_register,
            };
            self.pack(&mut source)?;
            return Ok(self.inputs.get(..whole).unwrap_or(&[]));
        };
        let image = self.inputs.get_mut(..n).unwrap_or(&mut []);
        for run in plan.runs() {
            let (bytes, channels) = run.spans();
            let Some(dst) = image.get_mut(bytes) else {
                continue;
            };
            match run.first {
                Slot::Ai(_) => {
                    if let Some(codes) = values.ai_codes.get(channels) {
                        for (b, code) in dst.chunks_exact_mut(2).zip(codes) {
                            b.copy_from_slice(&adc_code_to_ai(*code).to_le_bytes());
                        }
                    }
                }
                Slot::Ao(_) => {
                    if let Some(ao) = values.ao.get(channels) {
                        for (b, value) in dst.chunks_exact_mut(2).zip(ao) {
                            b.copy_from_slice(&value.to_le_bytes());
                        }
                    }
                }
                Slot::ErrorRegister => dst.fill(values.error_register),
            }
        }
        Ok(self.inputs.get(..whole).unwrap_or(&[]))
    }

    /// The RxPDO image layout in effect (SAFEOP, OP).
    pub fn rx_layout(&self) -> &ImageLayout<MAX_FIELDS> {
        &self.rx_layout
    }

    /// The TxPDO image layout in effect.
    pub fn tx_layout(&self) -> &ImageLayout<MAX_FIELDS> {
        &self.tx_layout
    }

    /// The output image buffer (SM2 content) to read into: the plain PDOs, then the
    /// oversampling part.
    pub fn output_image_mut(&mut self) -> &mut [u8] {
        let n =
            self.rx_layout.byte_len().min(MAX_IMAGE) + self.output_blocks_in_effect().byte_len();
        self.outputs.get_mut(..n).unwrap_or(&mut [])
    }

    /// The block counter in the output image (0x7010:01), if 0x1610 is assigned.
    pub fn output_block_counter(&self) -> Option<u16> {
        if !self.output_blocks_in_effect().counter {
            return None;
        }
        let at = self.rx_layout.byte_len().min(MAX_IMAGE);
        match self.outputs.get(at..at + output_blocks::COUNTER_BYTES) {
            Some(&[lo, hi]) => Some(u16::from_le_bytes([lo, hi])),
            _ => None,
        }
    }

    /// The update part of the output image (after the plain PDOs and the block counter).
    pub fn output_updates(&self) -> &[u8] {
        let b = self.output_blocks_in_effect();
        let start = self.rx_layout.byte_len().min(MAX_IMAGE)
            + if b.counter {
                output_blocks::COUNTER_BYTES
            } else {
                0
            };
        self.outputs
            .get(start..start + output_blocks::UPDATE_BYTES * b.updates())
            .unwrap_or(&[])
    }

    /// Unpacks the output image into `sink` (`ObjectAccess::write` per mapped object).
    pub fn unpack<A: ObjectAccess + ?Sized>(
        &self,
        sink: &mut A,
        state: AlState,
    ) -> Result<(), SdoAbortCode> {
        self.rx_layout.unpack(&self.outputs, sink, state)
    }

    /// Packs the inputs from `source` and returns the input image (SM3 content).
    pub fn pack<A: ObjectAccess + ?Sized>(
        &mut self,
        source: &mut A,
    ) -> Result<&[u8], SdoAbortCode> {
        let n = self.tx_layout.byte_len().min(MAX_IMAGE);
        let image = self.inputs.get_mut(..n).unwrap_or(&mut []);
        self.tx_layout.pack(source, image)?;
        Ok(image)
    }

    /// The direction of a mapping object this module holds.
    pub fn direction(&self, index: u16) -> Option<PdoDirection> {
        PdoDirection::of_mapping_index(index)
    }
}

/// The object access the process-data unpacking uses: collects the 0x6411 values of one
/// SM2 image (other mapped objects are ignored).
struct RxSink {
    ao: [i16; AO_CHANNELS],
}

impl ObjectAccess for RxSink {
    fn read(&mut self, _: u16, _: u8, _: &mut [u8]) -> Result<usize, SdoAbortCode> {
        Err(SdoAbortCode::ReadOfWriteOnly)
    }

    fn write(&mut self, index: u16, sub: u8, data: &[u8], _: AlState) -> Result<(), SdoAbortCode> {
        if index == 0x6411 {
            if let (Ok(i), [a, b]) = (channel(sub, AO_CHANNELS), data) {
                if let Some(slot) = self.ao.get_mut(i) {
                    *slot = i16::from_le_bytes([*a, *b]);
                }
            }
        }
        Ok(())
    }
}

/// The object access the process-data packing uses: the published AI values and the AO
/// values (a snapshot, so packing does not borrow the application data).
struct TxSource {
    ai: [i16; AI_CHANNELS],
    ao: [i16; AO_CHANNELS],
    error_register: u8,
}

impl ObjectAccess for TxSource {
    fn read(&mut self, index: u16, sub: u8, buf: &mut [u8]) -> Result<usize, SdoAbortCode> {
        match index {
            0x6401 => {
                let i = channel(sub, AI_CHANNELS)?;
                put(buf, &self.ai.get(i).copied().unwrap_or(0).to_le_bytes())
            }
            0x6411 => {
                let i = channel(sub, AO_CHANNELS)?;
                put(buf, &self.ao.get(i).copied().unwrap_or(0).to_le_bytes())
            }
            0x1001 => put(buf, &[self.error_register]),
            _ => Err(SdoAbortCode::CannotBeMapped),
        }
    }

    fn write(&mut self, _: u16, _: u8, _: &[u8], _: AlState) -> Result<(), SdoAbortCode> {
        Err(SdoAbortCode::WriteOfReadOnly)
    }
}

/// SM2/SM3 against the device description and the image length.
fn sm_matches(sm: &SyncManager, expect: &SyncManagerDesc, len: usize) -> bool {
    let mask = sm_control::MODE_MASK | sm_control::DIR_MASK;
    if len == 0 {
        return !sm.enabled() || sm.length == 0;
    }
    sm.enabled()
        && sm.start == expect.start
        && sm.control & mask == expect.control & mask
        && usize::from(sm.length) == len
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::products::analog_io::od;
    use coe_core::pdo::PdoEntry;
    use std::vec::Vec;

    /// A configuration of one RxPDO and one TxPDO, taken through PREOP -> SAFEOP.
    fn prepared(rx: &[PdoEntry], tx: &[PdoEntry]) -> ProcessData {
        let mut pd = ProcessData::new(
            [Mapping::with_entries(0x1600, rx), Mapping::new(0x1601)],
            [
                Mapping::with_entries(0x1A00, tx),
                Mapping::new(0x1A01),
                Mapping::new(0x1A02),
            ],
            &[0x1600],
            &[0x1A00],
        );
        let [_, _, e2, e3] = crate::products::analog_io::layout::SYNC_MANAGERS;
        let sm = |e: &SyncManagerDesc, len: usize| SyncManager {
            start: e.start,
            length: len as u16,
            control: e.control,
            activate: SyncManager::ACTIVATE_ENABLE,
            ..SyncManager::default()
        };
        let (sm2, sm3) = (sm(&e2, pd.output_len()), sm(&e3, pd.input_len()));
        pd.prepare(&od::OD, &sm2, &sm3, &e2, &e3).unwrap();
        pd
    }

    const VALUES: SlotValues = SlotValues {
        ai_codes: &[0x0204, 0xFFFC, 0x0608, 8, 10, 12, 14, 0xF0F0],
        ao: &[0x1122, -0x3344],
        error_register: 0x81,
    };

    fn generic_pack(pd: &mut ProcessData) -> Vec<u8> {
        let mut source = TxSource {
            ai: VALUES.ai_codes.map(adc_code_to_ai),
            ao: *VALUES.ao,
            error_register: VALUES.error_register,
        };
        pd.pack(&mut source).unwrap().to_vec()
    }

    fn run(offset: u8, first: Slot, count: u8) -> Run {
        Run {
            offset,
            first,
            count,
        }
    }

    /// Prepares `rx`/`tx`, checks the plans' runs, and that the fast path packs `packed`
    /// and unpacks `[0x34, 0x12, 0xFE, 0xFF]` to `ao` as the generic path does.
    fn check_fast_path(
        (rx, rx_runs): (&[PdoEntry], &[Run]),
        (tx, tx_runs): (&[PdoEntry], &[Run]),
        packed: &[u8],
        ao: [i16; AO_CHANNELS],
    ) {
        let mut pd = prepared(rx, tx);
        let (fast_rx, fast_tx) = pd.fast_plans();
        assert_eq!(fast_rx.unwrap().runs(), rx_runs);
        assert_eq!(fast_tx.unwrap().runs(), tx_runs);
        let fast = pd.pack_values(&VALUES).unwrap().to_vec();
        assert_eq!(fast, packed);
        assert_eq!(fast, generic_pack(&mut pd));

        pd.output_image_mut()
            .copy_from_slice(&[0x34, 0x12, 0xFE, 0xFF]);
        assert_eq!(pd.unpack_ao([7, 7], AlState::Op).unwrap(), ao);
        let mut sink = RxSink { ao: [7, 7] };
        pd.unpack(&mut sink, AlState::Op).unwrap();
        assert_eq!(sink.ao, ao);
    }

    #[test]
    fn byte_aligned_layouts_take_the_fast_path_with_the_generic_result() {
        let rx = [PdoEntry::new(0x6411, 2, 16), PdoEntry::new(0x6411, 1, 16)];
        let tx = [
            PdoEntry::new(0x6401, 8, 16),
            PdoEntry::new(0x1001, 0, 8),
            PdoEntry::new(0x0000, 0, 8),
            PdoEntry::new(0x6401, 1, 16),
        ];
        check_fast_path(
            (&rx, &[run(0, Slot::Ao(1), 1), run(2, Slot::Ao(0), 1)]),
            (
                &tx,
                &[
                    run(0, Slot::Ai(7), 1),
                    run(2, Slot::ErrorRegister, 1),
                    run(4, Slot::Ai(0), 1),
                ],
            ),
            &[0x78, 0x78, 0x81, 0, 0x02, 0x01],
            [-2, 0x1234],
        );
    }

    #[test]
    fn consecutive_channels_form_one_run() {
        let rx = [PdoEntry::new(0x6411, 1, 16), PdoEntry::new(0x6411, 2, 16)];
        let tx = [
            PdoEntry::new(0x6401, 1, 16),
            PdoEntry::new(0x6401, 2, 16),
            PdoEntry::new(0x1001, 0, 8),
            PdoEntry::new(0x0000, 0, 8),
            PdoEntry::new(0x6401, 5, 16),
            PdoEntry::new(0x6401, 4, 16),
            PdoEntry::new(0x6401, 6, 16),
            PdoEntry::new(0x6401, 7, 16),
        ];
        check_fast_path(
            (&rx, &[run(0, Slot::Ao(0), 2)]),
            (
                &tx,
                &[
                    run(0, Slot::Ai(0), 2),
                    run(4, Slot::ErrorRegister, 1),
                    run(6, Slot::Ai(4), 1),
                    run(8, Slot::Ai(3), 1),
                    run(10, Slot::Ai(5), 2),
                ],
            ),
            &[2, 1, 0xFE, 0x7F, 0x81, 0, 5, 0, 4, 0, 6, 0, 7, 0],
            [0x1234, -2],
        );
    }

    #[test]
    fn unaligned_layouts_fall_back_to_bit_packing() {
        // A 4-bit gap shifts everything after it off the byte grid.
        let rx = [
            PdoEntry::new(0x0000, 0, 4),
            PdoEntry::new(0x6411, 1, 16),
            PdoEntry::new(0x0000, 0, 4),
        ];
        let tx = [
            PdoEntry::new(0x0000, 0, 4),
            PdoEntry::new(0x6401, 1, 16),
            PdoEntry::new(0x0000, 0, 4),
        ];
        let mut pd = prepared(&rx, &tx);
        assert_eq!(pd.fast_plans(), (None, None));
        // 0x0102 shifted by 4 bits.
        assert_eq!(pd.pack_values(&VALUES).unwrap(), &[0x20, 0x10, 0x00]);
        pd.output_image_mut().copy_from_slice(&[0x40, 0x23, 0x01]);
        assert_eq!(pd.unpack_ao([7, 7], AlState::Op).unwrap(), [0x1234, 7]);
    }

    #[test]
    fn objects_without_a_slot_fall_back() {
        assert_eq!(Slot::of(0x6401, 9, 16), None);
        assert_eq!(Slot::of(0x6411, 0, 16), None);
        assert_eq!(Slot::of(0x6401, 1, 8), None);
        assert_eq!(Slot::of(0x1001, 1, 8), None);
        assert_eq!(Slot::of(0x1001, 0, 8), Some(Slot::ErrorRegister));
        // An AI in the outputs has no fast path.
        let layout = ImageLayout::build(
            &PdoAssignment::<RX_PDOS>::with_pdos(0x1C12, &[0x1600]),
            &[Mapping::with_entries(
                0x1600,
                &[PdoEntry::new(0x6401, 1, 16)],
            )],
        )
        .unwrap();
        assert!(FastImage::build(&layout, |s| matches!(s, Slot::Ao(_))).is_none());
        assert!(FastImage::build(&layout, |_| true).is_some());
    }

    /// Writes 0x1C13 as a master does (sub 0 = 0, the entries, sub 0 = n).
    fn assign_inputs(pd: &mut ProcessData, pdos: &[u16]) -> Result<(), SdoAbortCode> {
        let w = |pd: &mut ProcessData, sub: u8, data: &[u8]| {
            pd.write(0x1C13, sub, data, AlState::PreOp, &od::OD)
        };
        w(pd, 0, &[0])?;
        for (sub, pdo) in (1..).zip(pdos) {
            w(pd, sub, &pdo.to_le_bytes())?;
        }
        w(pd, 0, &[pdos.len() as u8])
    }

    fn sm_for(e: &SyncManagerDesc, len: usize) -> SyncManager {
        SyncManager {
            start: e.start,
            length: len as u16,
            control: e.control,
            activate: SyncManager::ACTIVATE_ENABLE,
            ..SyncManager::default()
        }
    }

    #[test]
    fn oversampling_pdos_in_the_input_assignment() {
        let mut pd = crate::products::analog_io::process_data();
        let mut all = std::vec![0x1A00, 0x1A10, 0x1A11];
        all.extend(0x1A20..0x1A28);
        assert_eq!(assign_inputs(&mut pd, &all), Ok(()));
        assert_eq!(pd.input_len(), 16 + 6 + 8 + 512);
        let mut buf = [0u8; 2];
        assert_eq!(pd.read(0x1C13, 0, &mut buf), Ok(1));
        assert_eq!(buf[0], 11);
        // Refused orders (0x06040043) and PDOs that do not exist (0x06090030) leave the
        // assignment as it was written last... sub 0 stays 0 after a refused sub 0.
        for bad in [&[0x1A20][..], &[0x1A10, 0x1A21], &[0x1A10, 0x1A00]] {
            assert_eq!(
                assign_inputs(&mut pd, bad),
                Err(SdoAbortCode::ParameterIncompatible),
                "{bad:x?}"
            );
        }
        assert_eq!(
            assign_inputs(&mut pd, &[0x1A10, 0x1A28]),
            Err(SdoAbortCode::ValueRangeExceeded)
        );
        // Not offered by a product without the objects (analog-io-can's configuration).
        let mut plain = ProcessData::new(
            [Mapping::new(0x1600), Mapping::new(0x1601)],
            [
                Mapping::new(0x1A00),
                Mapping::new(0x1A01),
                Mapping::new(0x1A02),
            ],
            &[],
            &[],
        );
        assert_eq!(
            assign_inputs(&mut plain, &[0x1A10]),
            Err(SdoAbortCode::ValueRangeExceeded)
        );
    }

    #[test]
    fn the_blocks_follow_the_plain_inputs_in_the_image() {
        let mut pd = crate::products::analog_io::process_data();
        assign_inputs(&mut pd, &[0x1A00, 0x1A10, 0x1A20]).unwrap();
        let [_, _, e2, e3] = crate::products::analog_io::layout::SYNC_MANAGERS;
        let (sm2, sm3) = (sm_for(&e2, pd.output_len()), sm_for(&e3, pd.input_len()));
        // SM3 of the plain length only: refused.
        let short = sm_for(&e3, 16);
        assert_eq!(
            pd.prepare(&od::OD, &sm2, &short, &e2, &e3),
            Err(AlStatusCode::InvalidInputConfiguration)
        );
        pd.prepare(&od::OD, &sm2, &sm3, &e2, &e3).unwrap();
        assert_eq!(
            *pd.input_blocks(),
            InputBlocks {
                status: true,
                time: false,
                sample_pdos: 1
            }
        );
        let blocks = pd.input_blocks_image_mut();
        assert_eq!(blocks.len(), 6 + 64);
        for (i, b) in blocks.iter_mut().enumerate() {
            *b = i as u8;
        }
        let image = pd.pack_values(&VALUES).unwrap().to_vec();
        assert_eq!(image.len(), 16 + 70);
        assert_eq!(&image[..2], &adc_code_to_ai(0x0204).to_le_bytes());
        assert!(image[16..].iter().enumerate().all(|(i, b)| *b == i as u8));
    }
}
