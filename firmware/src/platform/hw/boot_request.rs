//! The boot request word in the local SRAM ([`firmware::platform::boot::request`], at
//! [`firmware::platform::boot::layout::BOOT_REQUEST_ADDR`]): the application sets it and resets into
//! the bootloader; the bootloader takes it.

use firmware::platform::boot::layout::BOOT_REQUEST_ADDR;
use firmware::platform::boot::request::{is_request, CLEARED, REQUEST};

fn word() -> *mut [u32; 2] {
    BOOT_REQUEST_ADDR as *mut [u32; 2]
}

/// Sets the request and resets the CPU (SYSRESETREQ): the bootloader starts and stays.
pub fn enter_bootloader() -> ! {
    // SAFETY: two words of the local SRAM that both programs' linker scripts keep outside
    // their RAM region; nothing else refers to them.
    unsafe { core::ptr::write_volatile(word(), REQUEST) };
    cortex_m::peripheral::SCB::sys_reset()
}

/// Reads the request and clears it (a request counts for one reset). The bootloader's (it
/// includes this hardware layer too).
#[allow(dead_code)]
pub fn take() -> bool {
    // SAFETY: as in `enter_bootloader`.
    let words = unsafe { core::ptr::read_volatile(word()) };
    // SAFETY: as above.
    unsafe { core::ptr::write_volatile(word(), CLEARED) };
    is_request(words)
}
