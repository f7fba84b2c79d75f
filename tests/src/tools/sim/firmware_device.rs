//! A product's own device description on the board: the product, and the SII image
//! generated from its description by `coe_core::sii` (the image the ESC model loads and the
//! master reads).

use crate::rig::firmware_cpu::Device;
use coe_core::device::oversampling::Oversampling;
use coe_core::device::DeviceDescription;
use firmware::products::Product;

/// The SII EEPROM image of `desc`: the generated image, the rest of the EEPROM erased
/// (0xFF) as on a programmed part.
pub fn sii_image(desc: &DeviceDescription) -> Result<Vec<u8>, coe_core::sii::SiiError> {
    sii_image_with(desc, &Oversampling::NONE)
}

/// [`sii_image`] of a description with an oversampling part (a product's).
pub fn sii_image_with(
    desc: &DeviceDescription,
    os: &Oversampling,
) -> Result<Vec<u8>, coe_core::sii::SiiError> {
    let mut image = vec![0xFF; desc.eeprom.size_bytes as usize];
    coe_core::sii::generate_eeprom_with(desc, os, &mut image)?;
    Ok(image)
}

/// The module as `product` describes it, its CANopen node (if it has one) at `node_id`.
pub fn device_of(product: &'static Product, node_id: u8) -> Result<Device, String> {
    let desc = product.device;
    let sii = sii_image_with(desc, product.oversampling).map_err(|e| e.to_string())?;
    let description = format!(
        "the firmware's {} ({}, object dictionary of {} objects, generated SII image)",
        product.name,
        desc.names.device_name,
        desc.od.len()
    );
    Device::of(product, node_id, sii, description)
}

/// The default product ([`firmware::products::default`]).
pub fn device() -> Result<Device, String> {
    device_of(firmware::products::default(), super::DEFAULT_NODE_ID)
}
