//! The firmware's own device description on the board: its object dictionary, the
//! [`AppConfig`](firmware::stacks::ethercat::AppConfig) and default process data derived from it, and the
//! SII image generated from it by `coe_core::sii` (the image the ESC model loads and the
//! master reads).

use crate::rig::firmware_cpu::Device;
use coe_core::device::DeviceDescription;
use firmware::io::analog::process_data::ProcessData;
use firmware::products::analog_io::device::DEVICE;
use firmware::stacks::ethercat::AppConfig;

/// The SII EEPROM image of `desc`: the generated image, the rest of the EEPROM erased
/// (0xFF) as on a programmed part.
pub fn sii_image(desc: &DeviceDescription) -> Result<Vec<u8>, coe_core::sii::SiiError> {
    let mut image = vec![0xFF; desc.eeprom.size_bytes as usize];
    coe_core::sii::generate_eeprom(desc, &mut image)?;
    Ok(image)
}

/// The module as the firmware describes it (`firmware::products::analog_io::device::DEVICE`).
pub fn device() -> Result<Device, String> {
    let sii = sii_image(&DEVICE).map_err(|e| e.to_string())?;
    Ok(Device {
        description: format!(
            "the firmware's slave application ({}, object dictionary of {} objects, \
             generated SII image)",
            DEVICE.names.device_name,
            DEVICE.od.len()
        ),
        od: DEVICE.od,
        config: AppConfig::product(),
        process_data: ProcessData::product_default(),
        sii,
    })
}
