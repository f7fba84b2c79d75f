//! Process data: the PDO mapping (0x1600.., 0x1A00..) and assignment (0x1C12, 0x1C13)
//! configurable in PREOP, the process image layouts built from them at PREOP -> SAFEOP, the
//! SM2/SM3 checks against them, and the per-cycle copy SM2 -> outputs, inputs -> SM3.
//!
//! Validation and bit-exact packing are coe-core's ([`coe_core::pdo`]); this module owns the
//! configuration and decides the AL status codes:
//! - an assignment or mapping that does not validate: 0x0025 invalid output mapping /
//!   0x0024 invalid input mapping;
//! - SM2 (SM3) not matching the device description (start, mode and direction bits) or
//!   its length not the size of the assigned RxPDOs (TxPDOs), or enabled/disabled against
//!   the image: 0x001D InvalidOutputConfiguration (0x001E InvalidInputConfiguration).

use super::esc::{sm_control, SmConfig, SmExpect};
use coe_core::od::{ObjectAccess, ObjectDictionary};
use coe_core::pdo::{ImageLayout, PdoAssignment, PdoDirection, PdoMapping};
use coe_core::{AlState, AlStatusCode, SdoAbortCode};

/// RxPDO mapping objects the module offers.
pub const RX_PDOS: usize = 2;
/// TxPDO mapping objects the module offers.
pub const TX_PDOS: usize = 2;
/// Entries per mapping object.
pub const ENTRIES: usize = 8;
/// Largest process image per direction in bytes.
pub const MAX_IMAGE: usize = 32;
/// Largest number of mapped objects per direction.
pub const MAX_FIELDS: usize = 16;

/// One PDO mapping object.
pub type Mapping = PdoMapping<ENTRIES>;

/// The PDO configuration and the process images.
#[derive(Debug, Clone)]
pub struct ProcessData {
    rx: [Mapping; RX_PDOS],
    tx: [Mapping; TX_PDOS],
    rx_assign: PdoAssignment<RX_PDOS>,
    tx_assign: PdoAssignment<TX_PDOS>,
    defaults: (
        [Mapping; RX_PDOS],
        [Mapping; TX_PDOS],
        PdoAssignment<RX_PDOS>,
        PdoAssignment<TX_PDOS>,
    ),
    rx_layout: ImageLayout<MAX_FIELDS>,
    tx_layout: ImageLayout<MAX_FIELDS>,
    outputs: [u8; MAX_IMAGE],
    inputs: [u8; MAX_IMAGE],
}

/// Bits a PDO (and an assignment) may hold.
const MAX_BITS: u32 = (MAX_IMAGE * 8) as u32;

impl ProcessData {
    /// The default configuration: the mapping objects (their indices name them) and the
    /// assigned PDOs.
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
            outputs: [0; MAX_IMAGE],
            inputs: [0; MAX_IMAGE],
        }
    }

    /// Back to the default configuration (INIT).
    pub fn reset(&mut self) {
        let (rx, tx, ra, ta) = self.defaults;
        *self = Self {
            rx,
            tx,
            rx_assign: ra,
            tx_assign: ta,
            defaults: self.defaults,
            rx_layout: ImageLayout::new(),
            tx_layout: ImageLayout::new(),
            outputs: [0; MAX_IMAGE],
            inputs: [0; MAX_IMAGE],
        };
    }

    /// Size in bytes of the assigned RxPDOs (SM2 length).
    pub fn output_len(&self) -> usize {
        (self.rx_assign.bit_len(&self.rx) as usize).div_ceil(8)
    }

    /// Size in bytes of the assigned TxPDOs (SM3 length).
    pub fn input_len(&self) -> usize {
        (self.tx_assign.bit_len(&self.tx) as usize).div_ceil(8)
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
            0x1C12 => self.rx_assign.write_sub(sub, data, &self.rx, MAX_BITS),
            0x1C13 => self.tx_assign.write_sub(sub, data, &self.tx, MAX_BITS),
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
        sm2: &SmConfig,
        sm3: &SmConfig,
        expect2: &SmExpect,
        expect3: &SmExpect,
    ) -> Result<(), AlStatusCode> {
        let valid = |maps: &[Mapping]| maps.iter().all(|m| m.validate(od, MAX_BITS).is_ok());
        if !valid(&self.rx) || self.rx_assign.validate(&self.rx, MAX_BITS).is_err() {
            return Err(AlStatusCode::InvalidOutputMapping);
        }
        if !valid(&self.tx) || self.tx_assign.validate(&self.tx, MAX_BITS).is_err() {
            return Err(AlStatusCode::InvalidInputMapping);
        }
        let rx_layout = ImageLayout::build(&self.rx_assign, &self.rx)
            .map_err(|_| AlStatusCode::InvalidOutputMapping)?;
        let tx_layout = ImageLayout::build(&self.tx_assign, &self.tx)
            .map_err(|_| AlStatusCode::InvalidInputMapping)?;
        if rx_layout.byte_len() > MAX_IMAGE {
            return Err(AlStatusCode::InvalidOutputMapping);
        }
        if tx_layout.byte_len() > MAX_IMAGE {
            return Err(AlStatusCode::InvalidInputMapping);
        }
        if !sm_matches(sm2, expect2, rx_layout.byte_len()) {
            return Err(AlStatusCode::InvalidOutputConfiguration);
        }
        if !sm_matches(sm3, expect3, tx_layout.byte_len()) {
            return Err(AlStatusCode::InvalidInputConfiguration);
        }
        self.rx_layout = rx_layout;
        self.tx_layout = tx_layout;
        self.inputs = [0; MAX_IMAGE];
        Ok(())
    }

    /// The RxPDO image layout in effect (SAFEOP, OP).
    pub fn rx_layout(&self) -> &ImageLayout<MAX_FIELDS> {
        &self.rx_layout
    }

    /// The TxPDO image layout in effect.
    pub fn tx_layout(&self) -> &ImageLayout<MAX_FIELDS> {
        &self.tx_layout
    }

    /// The output image buffer (SM2 content) to read into.
    pub fn output_image_mut(&mut self) -> &mut [u8] {
        let n = self.rx_layout.byte_len().min(MAX_IMAGE);
        self.outputs.get_mut(..n).unwrap_or(&mut [])
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

/// SM2/SM3 against the device description and the image length.
fn sm_matches(sm: &SmConfig, expect: &SmExpect, len: usize) -> bool {
    let mask = sm_control::MODE_MASK | sm_control::DIR_MASK;
    if len == 0 {
        return !sm.enabled() || sm.len == 0;
    }
    sm.enabled()
        && sm.start == expect.start
        && sm.control & mask == expect.control & mask
        && usize::from(sm.len) == len
}
