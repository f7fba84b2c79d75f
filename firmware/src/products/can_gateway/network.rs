//! The CAN network as the EtherCAT master configures it: the entries of 0x8000 + 16n
//! (node configuration), 0x8001 / 0x8002 + 16n (the node's TPDO / RPDO mappings) and
//! 0xF800 (the CAN master's parameters), read from and written into the CANopen master's
//! own places (`coe_core::canopen::master`), which hold them while the master is stopped
//! (PREOP). Values are taken as written; [`prepare_place`] turns a place into what the
//! master boots (default COB-IDs resolved, PDOs without a mapping dropped) and the master's
//! check judges it at PREOP -> SAFEOP.

use super::od::{
    config_sub, master_sub, COB_ID_DEFAULT, COB_ID_NOT_VALID, FLAG_DISABLE_UNUSED_PDOS,
    FLAG_MANDATORY, NODE_PDOS, PDO_MAP_ENTRIES, POLICY_LOST_MANDATORY_AL_ERROR,
    POLICY_START_ALL_AT_ONCE,
};
use coe_core::canopen::master::config::{MasterConfig, NodeConfig, PdoConfig};
use coe_core::SdoAbortCode;

/// A value of an entry and its length in bytes.
pub type EntryValue = (u32, usize);

/// The predefined connection set's CAN-ID of a node's PDO: TPDO `k` (0-based) at 0x180 +
/// 0x100 k + node-ID, RPDO `k` at 0x200 + 0x100 k + node-ID.
pub const fn default_cob_id(tpdo: bool, k: usize, node: u8) -> u16 {
    let base = if tpdo { 0x180 } else { 0x200 };
    base + 0x100 * k as u16 + node as u16
}

/// A PDO place being configured: present as soon as a COB-ID or a mapping entry is written.
fn pdo_mut(slot: &mut Option<PdoConfig>, k: usize) -> &mut PdoConfig {
    slot.get_or_insert(PdoConfig {
        number: k as u16 + 1,
        cob_id: COB_ID_DEFAULT as u16,
        transmission_type: 1,
        inhibit_100us: 0,
        event_timer_ms: 0,
        deadline_ms: 0,
        mapping: [0; 8],
        mapped: 0,
    })
}

/// 0x8000 + 16n:`sub` of `cfg`.
pub fn read_config(cfg: &NodeConfig, sub: u8) -> Result<EntryValue, SdoAbortCode> {
    use config_sub::*;
    let cob = |p: &Option<PdoConfig>| match p {
        Some(p) => (u32::from(p.cob_id), 4),
        None => (COB_ID_NOT_VALID, 4),
    };
    let tt = |p: &Option<PdoConfig>| (u32::from(p.map_or(1, |p| p.transmission_type)), 1);
    let id = &cfg.identity;
    let flags = (u32::from(cfg.mandatory) * u32::from(FLAG_MANDATORY))
        | (u32::from(cfg.disable_unused_pdos) * u32::from(FLAG_DISABLE_UNUSED_PDOS));
    let first_tpdo = cfg.tpdo[0].or(cfg.tpdo[1]);
    Ok(match sub {
        0 => (u32::from(LAST), 1),
        NODE_ID => (u32::from(cfg.node_id), 1),
        DEVICE_TYPE => (id.device_type, 4),
        VENDOR_ID => (id.vendor_id, 4),
        PRODUCT_CODE => (id.product_code, 4),
        REVISION => (id.revision, 4),
        SERIAL => (id.serial, 4),
        FLAGS => (flags, 2),
        GUARD_TIME => (u32::from(cfg.guard_time_ms), 2),
        LIFE_FACTOR => (u32::from(cfg.life_time_factor), 1),
        HEARTBEAT_CONSUMER => (u32::from(cfg.heartbeat_consumer_ms), 2),
        HEARTBEAT_PRODUCER => (u32::from(cfg.heartbeat_producer_ms), 2),
        TPDO1_COB_ID => cob(&cfg.tpdo[0]),
        TPDO1_TYPE => tt(&cfg.tpdo[0]),
        TPDO2_COB_ID => cob(&cfg.tpdo[1]),
        TPDO2_TYPE => tt(&cfg.tpdo[1]),
        RPDO1_COB_ID => cob(&cfg.rpdo[0]),
        RPDO1_TYPE => tt(&cfg.rpdo[0]),
        RPDO2_COB_ID => cob(&cfg.rpdo[1]),
        RPDO2_TYPE => tt(&cfg.rpdo[1]),
        TPDO_EVENT_TIMER => (u32::from(first_tpdo.map_or(0, |p| p.event_timer_ms)), 2),
        TPDO_DEADLINE => (u32::from(first_tpdo.map_or(0, |p| p.deadline_ms)), 2),
        _ => return Err(SdoAbortCode::SubindexDoesNotExist),
    })
}

/// Writes 0x8000 + 16n:`sub` of `cfg` (the SDO server has checked the length and range).
pub fn write_config(cfg: &mut NodeConfig, sub: u8, v: u32) -> Result<(), SdoAbortCode> {
    use config_sub::*;
    let small = |v: u32| u16::try_from(v).map_err(|_| SdoAbortCode::ValueRangeExceeded);
    let set_cob = |slot: &mut Option<PdoConfig>, k: usize| -> Result<(), SdoAbortCode> {
        if v & COB_ID_NOT_VALID != 0 {
            *slot = None;
            return Ok(());
        }
        let id = u16::try_from(v).ok().filter(|id| *id <= 0x7FF);
        pdo_mut(slot, k).cob_id = id.ok_or(SdoAbortCode::ValueRangeExceeded)?;
        Ok(())
    };
    let set_tt = |slot: &mut Option<PdoConfig>, k: usize| -> Result<(), SdoAbortCode> {
        let tt = u8::try_from(v).map_err(|_| SdoAbortCode::ValueRangeExceeded)?;
        if (241..=253).contains(&tt) {
            return Err(SdoAbortCode::ValueRangeExceeded);
        }
        pdo_mut(slot, k).transmission_type = tt;
        Ok(())
    };
    let id = &mut cfg.identity;
    match sub {
        NODE_ID => cfg.node_id = u8::try_from(v).map_err(|_| SdoAbortCode::ValueRangeExceeded)?,
        DEVICE_TYPE => id.device_type = v,
        VENDOR_ID => id.vendor_id = v,
        PRODUCT_CODE => id.product_code = v,
        REVISION => id.revision = v,
        SERIAL => id.serial = v,
        FLAGS => {
            let known = u32::from(FLAG_MANDATORY | FLAG_DISABLE_UNUSED_PDOS);
            if v & !known != 0 {
                return Err(SdoAbortCode::ValueRangeExceeded);
            }
            cfg.mandatory = v & u32::from(FLAG_MANDATORY) != 0;
            cfg.disable_unused_pdos = v & u32::from(FLAG_DISABLE_UNUSED_PDOS) != 0;
        }
        GUARD_TIME => cfg.guard_time_ms = small(v)?,
        LIFE_FACTOR => cfg.life_time_factor = v as u8,
        HEARTBEAT_CONSUMER => cfg.heartbeat_consumer_ms = small(v)?,
        HEARTBEAT_PRODUCER => cfg.heartbeat_producer_ms = small(v)?,
        TPDO1_COB_ID => set_cob(&mut cfg.tpdo[0], 0)?,
        TPDO1_TYPE => set_tt(&mut cfg.tpdo[0], 0)?,
        TPDO2_COB_ID => set_cob(&mut cfg.tpdo[1], 1)?,
        TPDO2_TYPE => set_tt(&mut cfg.tpdo[1], 1)?,
        RPDO1_COB_ID => set_cob(&mut cfg.rpdo[0], 0)?,
        RPDO1_TYPE => set_tt(&mut cfg.rpdo[0], 0)?,
        RPDO2_COB_ID => set_cob(&mut cfg.rpdo[1], 1)?,
        RPDO2_TYPE => set_tt(&mut cfg.rpdo[1], 1)?,
        TPDO_EVENT_TIMER | TPDO_DEADLINE => {
            let ms = small(v)?;
            for (k, slot) in cfg.tpdo.iter_mut().take(NODE_PDOS).enumerate() {
                let p = pdo_mut(slot, k);
                if sub == TPDO_EVENT_TIMER {
                    p.event_timer_ms = ms;
                } else {
                    p.deadline_ms = ms;
                }
            }
        }
        0 => return Err(SdoAbortCode::WriteOfReadOnly),
        _ => return Err(SdoAbortCode::SubindexDoesNotExist),
    }
    Ok(())
}

/// The PDO place and the entry of a mapping object's sub (1..=16).
fn map_place(sub: u8) -> Result<(usize, usize), SdoAbortCode> {
    let i = usize::from(sub)
        .checked_sub(1)
        .filter(|i| *i < NODE_PDOS * PDO_MAP_ENTRIES)
        .ok_or(SdoAbortCode::SubindexDoesNotExist)?;
    Ok((i / PDO_MAP_ENTRIES, i % PDO_MAP_ENTRIES))
}

/// 0x8001 (`tpdo`) / 0x8002 + 16n:`sub` of `cfg`.
pub fn read_map(cfg: &NodeConfig, tpdo: bool, sub: u8) -> Result<EntryValue, SdoAbortCode> {
    if sub == 0 {
        return Ok(((NODE_PDOS * PDO_MAP_ENTRIES) as u32, 1));
    }
    let (k, e) = map_place(sub)?;
    let pdos = if tpdo { &cfg.tpdo } else { &cfg.rpdo };
    let entry = pdos
        .get(k)
        .copied()
        .flatten()
        .map_or(0, |p| p.entries().get(e).copied().unwrap_or(0));
    Ok((entry, 4))
}

/// Writes 0x8001 / 0x8002 + 16n:`sub`: a PDO's entries are a list; 0 ends it (the entries
/// after it go), an entry is appended only right after the last one.
pub fn write_map(cfg: &mut NodeConfig, tpdo: bool, sub: u8, v: u32) -> Result<(), SdoAbortCode> {
    if sub == 0 {
        return Err(SdoAbortCode::WriteOfReadOnly);
    }
    let (k, e) = map_place(sub)?;
    let pdos = if tpdo { &mut cfg.tpdo } else { &mut cfg.rpdo };
    let slot = pdos.get_mut(k).ok_or(SdoAbortCode::SubindexDoesNotExist)?;
    if v == 0 {
        if let Some(p) = slot.as_mut() {
            p.mapped = p.mapped.min(e as u8);
        }
        return Ok(());
    }
    if v & 0xFF == 0 || v & 0xFF > 64 {
        return Err(SdoAbortCode::ValueRangeExceeded);
    }
    let p = pdo_mut(slot, k);
    if e > usize::from(p.mapped) {
        // A gap in the list.
        return Err(SdoAbortCode::ValueRangeExceeded);
    }
    let total: u32 = p.entries().iter().take(e).map(|x| x & 0xFF).sum::<u32>() + (v & 0xFF);
    if total > 64 {
        return Err(SdoAbortCode::PdoLengthExceeded);
    }
    if let Some(m) = p.mapping.get_mut(e) {
        *m = v;
    }
    p.mapped = e as u8 + 1;
    Ok(())
}

/// What the master boots from a place: default COB-IDs resolved to the node's, PDOs that
/// map nothing dropped, the PDO numbers by place.
pub fn prepare_place(cfg: &mut NodeConfig) {
    let node = cfg.node_id;
    for (tpdo, pdos) in [(true, &mut cfg.tpdo), (false, &mut cfg.rpdo)] {
        for (k, slot) in pdos.iter_mut().enumerate() {
            if k >= NODE_PDOS || slot.is_some_and(|p| p.is_empty()) {
                *slot = None;
            }
            if let Some(p) = slot.as_mut() {
                p.number = k as u16 + 1;
                if u32::from(p.cob_id) == COB_ID_DEFAULT {
                    p.cob_id = default_cob_id(tpdo, k, node);
                }
            }
        }
    }
}

/// The gateway's policies besides the master's own parameters (0xF800:0A).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Policies {
    /// A mandatory node lost in OP is an AL error.
    pub lost_mandatory_al_error: bool,
}

/// The master's parameters as the gateway starts it (the EL6751's defaults: one SYNC per
/// EtherCAT cycle, the network reset at the start).
pub fn default_master_config() -> MasterConfig {
    MasterConfig {
        sync_multiplier: 1,
        reset_on_start: true,
        ..MasterConfig::default()
    }
}

/// 0xF800:`sub`.
pub fn read_master(
    cfg: &MasterConfig,
    policies: Policies,
    bit_rate: u32,
    sub: u8,
) -> Result<EntryValue, SdoAbortCode> {
    use master_sub::*;
    let policy_bits = (u32::from(cfg.start_all_at_once) * u32::from(POLICY_START_ALL_AT_ONCE))
        | (u32::from(policies.lost_mandatory_al_error) * u32::from(POLICY_LOST_MANDATORY_AL_ERROR));
    Ok(match sub {
        0 => (u32::from(LAST), 1),
        BIT_RATE => (bit_rate / 1000, 2),
        NODE_ID => (u32::from(cfg.node_id), 1),
        SYNC_COB_ID => (u32::from(cfg.sync_cob_id), 4),
        SYNC_MULTIPLIER => (u32::from(cfg.sync_multiplier), 1),
        SYNC_PERIOD => (cfg.sync_period_us, 4),
        SDO_TIMEOUT => (u32::from(cfg.sdo_timeout_ms), 2),
        BOOT_WAIT => (u32::from(cfg.boot_wait_ms), 2),
        RETRY => (u32::from(cfg.retry_ms), 2),
        HEARTBEAT => (u32::from(cfg.heartbeat_ms), 2),
        POLICIES => (policy_bits, 2),
        _ => return Err(SdoAbortCode::SubindexDoesNotExist),
    })
}

/// Writes 0xF800:`sub`.
pub fn write_master(
    cfg: &mut MasterConfig,
    policies: &mut Policies,
    sub: u8,
    v: u32,
) -> Result<(), SdoAbortCode> {
    use master_sub::*;
    let small = |v: u32| u16::try_from(v).map_err(|_| SdoAbortCode::ValueRangeExceeded);
    match sub {
        NODE_ID => cfg.node_id = v as u8,
        SYNC_COB_ID => {
            cfg.sync_cob_id = u16::try_from(v)
                .ok()
                .filter(|id| (1..=0x7FF).contains(id))
                .ok_or(SdoAbortCode::ValueRangeExceeded)?
        }
        SYNC_MULTIPLIER => cfg.sync_multiplier = v as u8,
        SYNC_PERIOD => cfg.sync_period_us = v,
        SDO_TIMEOUT => cfg.sdo_timeout_ms = small(v)?,
        BOOT_WAIT => cfg.boot_wait_ms = small(v)?,
        RETRY => cfg.retry_ms = small(v)?,
        HEARTBEAT => cfg.heartbeat_ms = small(v)?,
        POLICIES => {
            let known = u32::from(POLICY_START_ALL_AT_ONCE | POLICY_LOST_MANDATORY_AL_ERROR);
            if v & !known != 0 {
                return Err(SdoAbortCode::ValueRangeExceeded);
            }
            cfg.start_all_at_once = v & u32::from(POLICY_START_ALL_AT_ONCE) != 0;
            policies.lost_mandatory_al_error = v & u32::from(POLICY_LOST_MANDATORY_AL_ERROR) != 0;
        }
        BIT_RATE | 0 => return Err(SdoAbortCode::WriteOfReadOnly),
        _ => return Err(SdoAbortCode::SubindexDoesNotExist),
    }
    Ok(())
}
