//! The object dictionary: `analog-io`'s analog objects (without input oversampling) with
//! this product's identity and names.

use super::identity::{IDENTITY, NAMES};
use crate::products::analog_io::od::{
    ANALOG_OBJECTS, ANALOG_OBJECT_COUNT, MODULE_DESCRIPTION_OBJECT,
};
use crate::products::{identity_objects, merge_objects};
use coe_core::od::{ObjectDesc, ObjectDictionary};

/// Identity, names and the module description.
static PRODUCT_OBJECTS: [ObjectDesc; 5] = {
    let [a, b, c, d] = identity_objects!(IDENTITY, NAMES);
    [a, b, c, d, MODULE_DESCRIPTION_OBJECT]
};

/// The module's object dictionary.
pub static OD: ObjectDictionary = ObjectDictionary::new(&OBJECTS);
static OBJECTS: [ObjectDesc; ANALOG_OBJECT_COUNT + 5] =
    merge_objects(&[&ANALOG_OBJECTS, &PRODUCT_OBJECTS]);

const _: () = if let Err(e) = OD.validate() {
    panic!("{}", e.message())
};
