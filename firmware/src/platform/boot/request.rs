//! The boot request: how the application asks for the bootloader across a reset.
//!
//! A master's INIT -> BOOT request reaches the application, which writes [`REQUEST`] into the
//! two RAM words at [`crate::platform::boot::layout::BOOT_REQUEST_ADDR`] and resets the CPU
//! (SYSRESETREQ). The local SRAM keeps its content over that reset; at power-up it holds
//! noise, and the chance that noise is the magic and its complement is 2^-64. The bootloader
//! reads the words and clears them at once, so the request counts for one reset only.
//!
//! UNCONFIRMED (no board here): that the LPC1754's boot ROM leaves these 8 bytes below its
//! IAP area (0x1000_3FD8..0x1000_3FE0) untouched between a SYSRESETREQ and the bootloader.
//! Should it not, INIT -> BOOT would restart the application instead (the master's BOOT
//! request times out, nothing is lost); the remedy would be for the bootloader to read the
//! ESC's AL control before it starts the application. (Once it stays, it does read it:
//! [`crate::stacks::ethercat::boot_slave::BootSlave::start`].)

/// The magic of a request ("BOOT" in ASCII, little-endian).
pub const MAGIC: u32 = u32::from_le_bytes(*b"BOOT");

/// The two words of a request: the magic and its complement.
pub const REQUEST: [u32; 2] = [MAGIC, !MAGIC];

/// The two words after the bootloader has taken a request (or of no request).
pub const CLEARED: [u32; 2] = [0, 0];

/// Whether the two words are a request.
pub const fn is_request(words: [u32; 2]) -> bool {
    words[0] == MAGIC && words[1] == !MAGIC
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_the_exact_pair_is_a_request() {
        assert!(is_request(REQUEST));
        assert_eq!(REQUEST, [0x544F_4F42, 0xABB0_B0BD]);
        assert!(!is_request(CLEARED));
        assert!(!is_request([MAGIC, MAGIC]));
        assert!(!is_request([MAGIC, 0]));
        assert!(!is_request([!MAGIC, MAGIC]));
        assert!(!is_request([u32::MAX, u32::MAX]));
    }
}
