//! The products: each is a folder here that says what it is (identity, object dictionary,
//! device description, which stacks it composes around which application, which board
//! it is built for) and a line in the list below. The image of a product is the
//! application binary built with the cargo feature of its name (`cargo xtask build
//! --product NAME`); the first product is the default of every command.
//!
//! | product          | board                       | stacks                                   |
//! |------------------|-----------------------------|------------------------------------------|
//! | [`analog_io`]    | thesis board, no CAN        | EtherCAT slave + FoE, analog I/O         |
//! | [`analog_io_can`] | thesis board with CAN transceiver | the same plus the CANopen node on CAN1 |
//! | [`analog_io_stm32`] | STM32F103 + ET1100 (FSMC) board | EtherCAT slave (no FoE), analog I/O |
//!
//! Adding a product: a folder with its `mod.rs` giving `PRODUCT` (a [`Product`]), its line
//! in `products!` below, and the cargo feature of its name in `firmware/Cargo.toml`
//! (which names the stacks its image runs); the build refuses a list and features that
//! disagree.

use crate::platform::board::Board;
use crate::platform::boot::header::Target;
use coe_core::device::oversampling::Oversampling;
use coe_core::device::DeviceDescription;
use coe_core::eds::EdsInfo;
use coe_core::od::ObjectDesc;

/// What the tools and the tests need to know of a product.
#[derive(Debug, Clone, Copy)]
pub struct Product {
    /// The name: `--product NAME`, the cargo feature that selects it for the image, the
    /// file names of its image and update file.
    pub name: &'static str,
    /// One line for people.
    pub summary: &'static str,
    /// The board it is built for: its image's bootloader is that board's.
    pub board: &'static Board,
    /// What its update files are built for (identity, board, the board options it needs);
    /// `None` for a product without firmware updates (its board has no bootloader).
    pub update: Option<Target>,
    /// The device description the SII image and the ESI file are generated from.
    pub device: &'static DeviceDescription,
    /// The oversampling part of the description (replicated PDOs listed once in the ESI
    /// and the SII; `coe_core::device::oversampling`).
    pub oversampling: &'static Oversampling,
    /// CANopen on CAN, if the product has it: the EDS's own facts and the node-ID.
    pub can: Option<CanFacts>,
    /// The flash and static RAM its application image may use.
    pub budget: Budget,
    /// How its image is compiled.
    pub build: ImageBuild,
}

/// The release profile's settings of a product's image (`cargo xtask build` applies them;
/// chosen by measurement, speed first where the budget allows: docs/book/products.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ImageBuild {
    /// `opt-level` of the release profile: "s", "z", "1", "2" or "3".
    pub opt_level: &'static str,
    /// LLVM's machine outliner on every function (code sequences repeated across the image
    /// become one shared copy: smaller, a little slower).
    pub machine_outliner: bool,
}

/// A product's CANopen device on CAN, as its EDS and the tools see it.
#[derive(Debug, Clone, Copy)]
pub struct CanFacts {
    /// The EDS's own facts (file version, bit rates).
    pub eds: EdsInfo,
    /// The node-ID unless configured otherwise.
    pub node_id: u8,
}

/// Flash and static RAM an application image may use (bytes).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Budget {
    /// Flash: from the vector table to the end of `.data`'s initial values.
    pub flash: u32,
    /// Static RAM: `.data + .bss + .uninit` (the stack takes the rest).
    pub ram: u32,
}

/// The list: `module = "name"`, the default first. It declares the modules, gives
/// [`PRODUCTS`], and makes the product whose cargo feature is on [`selected`] (the image's).
macro_rules! products {
    ($($(#[$doc:meta])* $module:ident = $name:literal,)+) => {
        $($(#[$doc])* pub mod $module;)+

        /// Every product, the default first.
        pub static PRODUCTS: [&Product; [$($name),+].len()] = [$(&$module::PRODUCT),+];

        $(
            /// The product the image is built for (its cargo feature is on).
            #[cfg(feature = $name)]
            pub use $module as selected;
        )+

        #[cfg(all(target_os = "none", not(any($(feature = $name),+))))]
        compile_error!("the image needs one product: build it with `cargo xtask build --product NAME`");

        /// The names, in the order of [`PRODUCTS`].
        pub const NAMES: [&str; [$($name),+].len()] = [$($name),+];
    };
}

products! {
    /// The thesis board's module: EtherCAT, FoE, the analog I/O.
    analog_io = "analog-io",
    /// The same with CANopen on CAN1, for the board with a CAN transceiver.
    analog_io_can = "analog-io-can",
    /// The analog module on the STM32F103 + ET1100 (FSMC) board: CoE, no FoE.
    analog_io_stm32 = "analog-io-stm32",
}

/// The CAN gateway (an EtherCAT slave that is a CANopen master on CAN1, issue 28): its
/// application, dictionary and device description, host-tested. Not in the list yet: its
/// image is over the application slot (docs/book/gateway.md, "Image size").
pub mod can_gateway;

/// The default product (the thesis board's).
pub fn default() -> &'static Product {
    PRODUCTS[0]
}

/// The product called `name`.
pub fn find(name: &str) -> Option<&'static Product> {
    PRODUCTS.iter().copied().find(|p| p.name == name)
}

/// The dictionary of `parts`, each in index order, as one table in index order: for
/// `static` tables (at compile time, where a failed assertion is a build error). `N` must be
/// the number of objects in all parts, and the indices must differ, which
/// `ObjectDictionary::validate` checks.
pub const fn merge_objects<const N: usize>(parts: &[&[ObjectDesc]]) -> [ObjectDesc; N] {
    let mut next = [0usize; 8];
    assert!(parts.len() <= next.len(), "at most 8 parts");
    assert!(
        !parts.is_empty() && !parts[0].is_empty(),
        "a first part with objects"
    );
    let mut out = [parts[0][0]; N];
    let mut n = 0;
    loop {
        // The part whose next object has the lowest index.
        let mut best: Option<usize> = None;
        let mut p = 0;
        while p < parts.len() {
            if next[p] < parts[p].len() {
                let index = parts[p][next[p]].index;
                best = match best {
                    Some(b) if parts[b][next[b]].index <= index => Some(b),
                    _ => Some(p),
                };
            }
            p += 1;
        }
        let Some(b) = best else {
            break;
        };
        assert!(n < N, "more objects than the table holds");
        out[n] = parts[b][next[b]];
        next[b] += 1;
        n += 1;
    }
    assert!(n == N, "fewer objects than the table holds");
    out
}

/// The objects that name a product, from its `Identity` and `Names`: 0x1008 device name,
/// 0x1009 hardware version, 0x100A software version, 0x1018 identity (as an array of the
/// four, in index order).
macro_rules! identity_objects {
    ($identity:expr, $names:expr) => {{
        use coe_core::od::{DataType, EntryDesc, ObjectDesc, Value};
        const U32: DataType = DataType::Unsigned32;
        const RO: coe_core::od::Access = coe_core::od::Access::RO;
        [
            ObjectDesc::var(
                0x1008,
                "Device name",
                &[EntryDesc::string(0, "Device name", $names.device_name)],
            ),
            ObjectDesc::var(
                0x1009,
                "Hardware version",
                &[EntryDesc::string(
                    0,
                    "Hardware version",
                    $names.hardware_version,
                )],
            ),
            ObjectDesc::var(
                0x100A,
                "Software version",
                &[EntryDesc::string(
                    0,
                    "Software version",
                    $names.software_version,
                )],
            ),
            ObjectDesc::record(
                0x1018,
                "Identity",
                DataType::Identity,
                &[
                    EntryDesc::count(4),
                    EntryDesc::new(1, "Vendor ID", U32, RO)
                        .with_default(Value::Uint($identity.vendor_id as u64)),
                    EntryDesc::new(2, "Product code", U32, RO)
                        .with_default(Value::Uint($identity.product_code as u64)),
                    EntryDesc::new(3, "Revision", U32, RO)
                        .with_default(Value::Uint($identity.revision as u64)),
                    EntryDesc::new(4, "Serial number", U32, RO)
                        .with_default(Value::Uint($identity.serial_number as u64)),
                ],
            ),
        ]
    }};
}
pub(crate) use identity_objects;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::platform::board::Mcu;
    use std::collections::BTreeSet;

    #[test]
    fn names_are_unique_and_found() {
        let names: BTreeSet<&str> = PRODUCTS.iter().map(|p| p.name).collect();
        assert_eq!(names.len(), PRODUCTS.len());
        for p in PRODUCTS {
            assert_eq!(find(p.name).map(|f| f.name), Some(p.name));
        }
        assert_eq!(default().name, "analog-io");
        assert!(find("analog-io-pro").is_none());
    }

    /// Every product has its own product code, names and update target, and runs on a
    /// board that has what it needs.
    #[test]
    fn products_differ_where_they_must() {
        let codes: BTreeSet<u32> = PRODUCTS
            .iter()
            .map(|p| p.device.identity.product_code)
            .collect();
        assert_eq!(codes.len(), PRODUCTS.len(), "product codes");
        for p in PRODUCTS {
            assert_eq!(
                p.update.is_some(),
                p.board.mcu().has_bootloader(),
                "{}",
                p.name
            );
            if let Some(update) = p.update {
                assert_eq!(update.product_code, p.device.identity.product_code);
                assert_eq!(update.vendor_id, p.device.identity.vendor_id);
                assert_eq!(update.vendor_id, p.board.vendor_id);
                assert_eq!(update.board, p.board.design);
                assert_eq!(update.hardware_revision, p.board.revision);
                assert!(p.board.options.covers(update.needs), "{}", p.name);
            }
            // FoE in the mailbox exactly where there is a bootloader to take the files.
            assert_eq!(
                p.device.mailbox.protocols.0 & coe_core::device::MailboxProtocols::FOE != 0,
                p.board.mcu().has_bootloader(),
                "{}: FoE and the bootloader go together",
                p.name
            );
            let board_pdi = match p.board.mcu() {
                Mcu::Lpc1754 => crate::platform::board::PDI,
                Mcu::Stm32f103vc => crate::platform::stm32f1::esc_pdi::PDI,
            };
            assert_eq!(p.device.pdi, board_pdi, "{}: the board's PDI", p.name);
            assert!(p.budget.flash <= p.board.mcu().app_flash_max());
            assert_eq!(
                p.can.is_some(),
                p.device.od.find(0x1017).is_some(),
                "{}: CAN facts and CAN objects go together",
                p.name
            );
        }
    }

    /// The cargo features of the image are the list's names.
    #[test]
    fn every_product_has_its_cargo_feature() {
        let manifest = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/Cargo.toml"))
            .expect("the firmware's Cargo.toml");
        for name in NAMES {
            assert!(
                manifest
                    .lines()
                    .any(|l| l.starts_with(&std::format!("{name} = ["))),
                "firmware/Cargo.toml has no feature {name:?}"
            );
        }
    }

    #[test]
    fn merging_keeps_index_order() {
        use coe_core::od::{Access, DataType, EntryDesc};
        static E: [EntryDesc; 1] = [EntryDesc::new(0, "x", DataType::Unsigned8, Access::RO)];
        const fn o(index: u16) -> ObjectDesc {
            ObjectDesc::var(index, "x", &E)
        }
        static A: [ObjectDesc; 3] = [o(1), o(4), o(9)];
        static B: [ObjectDesc; 2] = [o(2), o(5)];
        static C: [ObjectDesc; 1] = [o(3)];
        static M: [ObjectDesc; 6] = merge_objects(&[&A, &B, &C]);
        let indices: std::vec::Vec<u16> = M.iter().map(|o| o.index).collect();
        assert_eq!(indices, [1, 2, 3, 4, 5, 9]);
    }
}
