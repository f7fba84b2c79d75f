//! The oversampling part of a device description: replicated PDOs (ETG.2000 PDO attributes
//! `OSFac`, `OSMin`, `OSMax`, `OSIndexInc`) and DC op modes that carry their own PDO
//! assignment (ESI `Dc/OpMode/Sm/Pdo@OSFac`, one SII DC category entry each).
//!
//! A replicated PDO is a group of mapping objects in the dictionary: the base and its
//! replicas `base + 1 .. base + max - 1`, replica k mapping what the base maps with the
//! object index increased by `k * index_increment`. A master picks the factor n by assigning
//! the first n of them (0x1C12/0x1C13 over SDO, or TwinCAT from an op mode's `OSFac`); the
//! image then holds n copies of the base's layout. The ESI and the SII list only the base,
//! with its attributes (as Beckhoff's EL2262 SII and EL3632 ESI do); the dictionary holds
//! every replica, so a master that reads the mappings over SDO sizes the image itself.
//!
//! It is kept beside the [`DeviceDescription`] rather than in it, so descriptions without
//! oversampling stay as they are: [`crate::esi::write_esi`] and [`crate::sii::generate`]
//! are [`crate::esi::write_esi_with`] and [`crate::sii::generate_with`] with
//! [`Oversampling::NONE`], and write the same bytes as before.

use super::{
    default_count, default_u32, find_object, DcOpMode, DescError, DescErrorKind, DeviceDescription,
};
use crate::abort::SdoAbortCode;
use crate::pdo::{PdoDirection, PdoEntry};

/// A replicated PDO: mapping objects `base .. base + max_factor - 1`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PdoReplicas {
    /// The first mapping object (the one the ESI and SII list).
    pub base: u16,
    /// The factor a configuration tool offers first (`OSFac`).
    pub default_factor: u8,
    /// Smallest factor (`OSMin`, at least 1).
    pub min_factor: u8,
    /// Largest factor (`OSMax`): the number of mapping objects of the group.
    pub max_factor: u8,
    /// How much the mapped object index grows from one replica to the next (`OSIndexInc`).
    pub index_increment: u16,
}

impl PdoReplicas {
    /// Whether `pdo` belongs to the group, and as which replica (0 = the base).
    pub const fn replica(&self, pdo: u16) -> Option<u8> {
        if pdo >= self.base && ((pdo - self.base) as u32) < self.max_factor as u32 {
            Some((pdo - self.base) as u8)
        } else {
            None
        }
    }

    /// The mapping entry of replica `k` for the base's entry `entry` (a gap stays a gap).
    pub const fn replicated(&self, entry: PdoEntry, k: u8) -> PdoEntry {
        if entry.is_gap() {
            return entry;
        }
        let index = entry.index as u32 + k as u32 * self.index_increment as u32;
        PdoEntry::new(index as u16, entry.subindex, entry.bit_len)
    }
}

/// A PDO in an op mode's assignment: one plain PDO (`factor` 0), or the first `factor`
/// PDOs of a replicated group named by its base (ESI `Pdo OSFac`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct OpModePdo {
    /// The PDO (the base of a group when `factor` is given).
    pub index: u16,
    /// Replicas assigned (0: a plain PDO, no `OSFac`).
    pub factor: u8,
}

impl OpModePdo {
    /// A plain PDO.
    pub const fn plain(index: u16) -> Self {
        Self { index, factor: 0 }
    }

    /// The first `factor` PDOs of the group based at `base`.
    pub const fn replicated(base: u16, factor: u8) -> Self {
        Self {
            index: base,
            factor,
        }
    }

    /// How many mapping objects this assigns.
    pub const fn copies(&self) -> u8 {
        if self.factor == 0 {
            1
        } else {
            self.factor
        }
    }
}

/// The PDO assignment of one process-data SyncManager in an op mode (ESI `OpMode/Sm`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct OpModeSm {
    /// SyncManager number.
    pub sm: u8,
    /// The PDOs in assignment order.
    pub pdos: &'static [OpModePdo],
}

/// A DC op mode with its own PDO assignment.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct OpModeWithPdos {
    /// Name, activation and SYNC0/SYNC1 factors, as the plain op modes have them.
    pub mode: DcOpMode,
    /// The assignment per process-data SyncManager.
    pub sms: &'static [OpModeSm],
}

/// The oversampling part of a device description.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Oversampling {
    /// The replicated PDOs.
    pub replicas: &'static [PdoReplicas],
    /// Op modes after [`crate::device::DcDesc::op_modes`], each with its assignment.
    pub op_modes: &'static [OpModeWithPdos],
}

impl Oversampling {
    /// No oversampling: the description alone.
    pub const NONE: Self = Self {
        replicas: &[],
        op_modes: &[],
    };

    /// The group `pdo` belongs to and its replica number (0 = the base).
    pub const fn group_of(&self, pdo: u16) -> Option<(&'static PdoReplicas, u8)> {
        let groups: &'static [PdoReplicas] = self.replicas;
        let mut i = 0;
        while i < groups.len() {
            if let Some(k) = groups[i].replica(pdo) {
                return Some((&groups[i], k));
            }
            i += 1;
        }
        None
    }

    /// Whether a PDO list (ESI `RxPdo`/`TxPdo`, SII PDO categories) names `pdo`: every PDO
    /// but the replicas after a group's base.
    pub const fn is_listed(&self, pdo: u16) -> bool {
        !matches!(self.group_of(pdo), Some((_, k)) if k > 0)
    }

    /// Checks a PDO assignment (0x1C12/0x1C13 when sub 0 is written): the replicas of a
    /// group follow its base one by one, in order, and a group appears once, so the image
    /// holds the first n copies; else 0x06040043 (general parameter incompatibility).
    pub fn check_assignment(&self, pdos: &[u16]) -> Result<(), SdoAbortCode> {
        for (i, pdo) in pdos.iter().enumerate() {
            let Some((group, k)) = self.group_of(*pdo) else {
                continue;
            };
            let previous = i.checked_sub(1).and_then(|p| pdos.get(p));
            let follows = match k {
                0 => !pdos.iter().take(i).any(|p| self.is_in(group, *p)),
                k => previous == Some(&(group.base + u16::from(k) - 1)),
            };
            if !follows {
                return Err(SdoAbortCode::ParameterIncompatible);
            }
        }
        Ok(())
    }

    fn is_in(&self, group: &PdoReplicas, pdo: u16) -> bool {
        group.replica(pdo).is_some()
    }

    /// Checks this part against `desc`; usable in a `const` item. Rejected: factor limits
    /// that are 0, reversed or do not hold the default ([`DescErrorKind::BadOversamplingFactors`]);
    /// a replica that is missing, of the other direction, or not mapping what the base maps
    /// moved by the index increment ([`DescErrorKind::ReplicaMismatch`], subindex = the
    /// replica); an op mode naming a SyncManager that carries no process data, a PDO that
    /// does not exist or is of the other direction, a replica instead of its base, or a
    /// factor outside its group's limits or on a plain PDO ([`DescErrorKind::BadOpModePdo`],
    /// index = the PDO, subindex = the SM); an op mode whose image exceeds the SyncManager
    /// ([`DescErrorKind::OpModeImageLargerThanSm`]); an op mode without a name
    /// ([`DescErrorKind::EmptyName`]).
    pub const fn validate(&self, desc: &DeviceDescription) -> Result<(), DescError> {
        let groups: &'static [PdoReplicas] = self.replicas;
        let mut g = 0;
        while g < groups.len() {
            if let Err(e) = validate_group(desc, &groups[g]) {
                return Err(e);
            }
            g += 1;
        }
        let modes: &'static [OpModeWithPdos] = self.op_modes;
        let mut m = 0;
        while m < modes.len() {
            if modes[m].mode.name.is_empty() {
                return Err(DescError::new(DescErrorKind::EmptyName, 0, 0));
            }
            let sms: &'static [OpModeSm] = modes[m].sms;
            let mut s = 0;
            while s < sms.len() {
                if let Err(e) = self.validate_sm(desc, &sms[s]) {
                    return Err(e);
                }
                s += 1;
            }
            m += 1;
        }
        Ok(())
    }

    const fn validate_sm(&self, desc: &DeviceDescription, sm: &OpModeSm) -> Result<(), DescError> {
        let sms: &'static [super::SyncManagerDesc] = desc.sync_managers;
        let (direction, room) = match (sm.sm as usize) < sms.len() {
            true => match sms[sm.sm as usize].role.pdo_direction() {
                Some(d) => (d, sms[sm.sm as usize].len as u32 * 8),
                None => return Err(bad_pdo(0, sm.sm)),
            },
            false => return Err(bad_pdo(0, sm.sm)),
        };
        let pdos: &'static [OpModePdo] = sm.pdos;
        let mut bits = 0u32;
        let mut i = 0;
        while i < pdos.len() {
            let pdo = pdos[i];
            let object = find_object(desc.od, pdo.index);
            let ok_direction = matches!(
                PdoDirection::of_mapping_index(pdo.index),
                Some(d) if d as u8 == direction as u8
            );
            if object.is_none() || !ok_direction {
                return Err(bad_pdo(pdo.index, sm.sm));
            }
            match self.group_of(pdo.index) {
                Some((_, k)) if k > 0 => return Err(bad_pdo(pdo.index, sm.sm)),
                Some((group, _))
                    if pdo.factor != 0
                        && (pdo.factor < group.min_factor || pdo.factor > group.max_factor) =>
                {
                    return Err(bad_pdo(pdo.index, sm.sm));
                }
                None if pdo.factor != 0 => return Err(bad_pdo(pdo.index, sm.sm)),
                _ => {}
            }
            bits += pdo_bits(object) * pdo.copies() as u32;
            i += 1;
        }
        if bits > room {
            return Err(DescError::new(
                DescErrorKind::OpModeImageLargerThanSm,
                0,
                sm.sm,
            ));
        }
        Ok(())
    }
}

const fn bad_pdo(index: u16, sm: u8) -> DescError {
    DescError::new(DescErrorKind::BadOpModePdo, index, sm)
}

/// Bits of a PDO's default mapping.
const fn pdo_bits(object: Option<&'static crate::od::ObjectDesc>) -> u32 {
    let n = default_count(object);
    let mut bits = 0;
    let mut sub = 1;
    while sub <= n {
        if let Some(raw) = default_u32(object, sub) {
            bits += PdoEntry::from_u32(raw).bit_len as u32;
        }
        sub += 1;
    }
    bits
}

const fn validate_group(desc: &DeviceDescription, group: &PdoReplicas) -> Result<(), DescError> {
    if group.min_factor == 0
        || group.min_factor > group.max_factor
        || group.default_factor < group.min_factor
        || group.default_factor > group.max_factor
    {
        return Err(DescError::new(
            DescErrorKind::BadOversamplingFactors,
            group.base,
            0,
        ));
    }
    let base = find_object(desc.od, group.base);
    let direction = PdoDirection::of_mapping_index(group.base);
    if base.is_none() || direction.is_none() {
        return Err(DescError::new(
            DescErrorKind::ReplicaMismatch,
            group.base,
            0,
        ));
    }
    let n = default_count(base);
    let mut k = 1;
    while k < group.max_factor {
        let index = group.base as u32 + k as u32;
        let mismatch = DescError::new(DescErrorKind::ReplicaMismatch, index as u16, k);
        let same_direction = match (PdoDirection::of_mapping_index(index as u16), direction) {
            (Some(a), Some(b)) => a as u8 == b as u8,
            _ => false,
        };
        let replica = find_object(desc.od, index as u16);
        if index > 0xFFFF || !same_direction || replica.is_none() || default_count(replica) != n {
            return Err(mismatch);
        }
        let mut sub = 1;
        while sub <= n {
            let expected = match default_u32(base, sub) {
                Some(raw) => group.replicated(PdoEntry::from_u32(raw), k).to_u32(),
                None => return Err(mismatch),
            };
            match default_u32(replica, sub) {
                Some(raw) if raw == expected => {}
                _ => return Err(mismatch),
            }
            sub += 1;
        }
        k += 1;
    }
    Ok(())
}

#[cfg(test)]
pub(crate) mod tests;
