//! The module's object dictionary: `analog-io`'s analog objects
//! ([`analog_io::od::ANALOG_OBJECTS`]), the CANopen node's communication objects (0x1005..,
//! 0x1400.., 0x1800.., with the defaults of [`super::can::COMM_DEFAULTS`]), the objects
//! that decide which fieldbus drives the outputs and when TPDOs go out on a change, and
//! this product's identity.

use super::can::{
    AI_INTERRUPT_ENABLE_INDEX, COMM_DEFAULTS, HEARTBEAT_CONSUMERS, PROCESS_DATA_SOURCE_INDEX,
    SOURCE_CAN, SOURCE_ETHERCAT,
};
use super::identity::{IDENTITY, NAMES};
use crate::io::analog::process_data::{RX_PDOS, TX_PDOS};
use crate::products::analog_io;
use crate::products::analog_io::od::{ANALOG_OBJECTS, ANALOG_OBJECT_COUNT};
use crate::products::{identity_objects, merge_objects};
use coe_core::canopen::objects::CommObjects;
use coe_core::od::{Access, DataType, EntryDesc, ObjectDesc, ObjectDictionary, Value, ValueRange};

/// The communication objects with the product's defaults.
static CAN: CommObjects<RX_PDOS, TX_PDOS, { HEARTBEAT_CONSUMERS + 1 }> =
    CommObjects::new(&COMM_DEFAULTS);

/// The communication objects, in index order.
static CAN_OBJECTS: [ObjectDesc; 16] = [
    CAN.sync_cob_id(),
    CAN.cycle_period(),
    CAN.guard_time(),
    CAN.life_factor(),
    CAN.emcy_cob_id(),
    CAN.emcy_inhibit(),
    CAN.consumers(),
    CAN.producer(),
    CAN.sync_overflow(),
    CAN.error_behaviour(),
    CAN.sdo_server(),
    CAN.rpdo(0),
    CAN.rpdo(1),
    CAN.tpdo(0),
    CAN.tpdo(1),
    CAN.tpdo(2),
];

/// The objects that make the dictionary this product's, in index order.
static PRODUCT_OBJECTS: [ObjectDesc; 7] = {
    let [a, b, c, d] = identity_objects!(IDENTITY, NAMES);
    [
        a,
        b,
        c,
        d,
        analog_io::od::MODULE_DESCRIPTION_OBJECT,
        ObjectDesc::var(
            PROCESS_DATA_SOURCE_INDEX,
            "Process data source",
            &[
                EntryDesc::new(0, "Process data source", DataType::Unsigned8, Access::RW)
                    .with_default(Value::Uint(SOURCE_ETHERCAT as u64))
                    .with_range(&ValueRange {
                        min: Value::Uint(SOURCE_ETHERCAT as u64),
                        max: Value::Uint(SOURCE_CAN as u64),
                    }),
            ],
        ),
        ObjectDesc::var(
            AI_INTERRUPT_ENABLE_INDEX,
            "Analog input global interrupt enable",
            &[EntryDesc::new(
                0,
                "Analog input global interrupt enable",
                DataType::Boolean,
                Access::RW,
            )
            .with_default(Value::Uint(0))],
        ),
    ]
};

/// The module's object dictionary.
pub static OD: ObjectDictionary = ObjectDictionary::new(&OBJECTS);
static OBJECTS: [ObjectDesc; ANALOG_OBJECT_COUNT + 16 + 7] =
    merge_objects(&[&ANALOG_OBJECTS, &CAN_OBJECTS, &PRODUCT_OBJECTS]);

const _: () = if let Err(e) = OD.validate() {
    panic!("{}", e.message())
};
