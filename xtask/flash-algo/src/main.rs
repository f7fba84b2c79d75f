//! The LPC1754 flash algorithm binary for probe-rs (a stub on the host; `cargo xtask flash`
//! builds it for thumbv7m-none-eabi and turns it into the target description).
//!
//! CMSIS-Pack entry points, called by probe-rs with the core halted, SP and LR set up:
//! `Init(adr, clk, fnc)`, `UnInit(fnc)`, `EraseSector(adr)`, `EraseChip()`,
//! `ProgramPage(adr, sz, buf)`, `Verify(adr, sz, buf)`. The logic is the host-tested library;
//! this file only holds what needs the chip.
//!
//! **Clock.** The IAP ROM times erase and write pulses from the CPU clock it is told (kHz).
//! `Init` puts the CPU on the 4 MHz internal RC oscillator without PLL0 (disconnect and
//! disable PLL0, CLKSRCSEL = IRC, CCLKCFG = 0 i.e. divide by 1: UM10360 4.5.13 sequence) and
//! tells the ROM 4000 kHz. That is the reset state, so after probe-rs' reset-and-halt nothing
//! changes; when probe-rs attaches to a running firmware (PLL0 at 100 MHz), it makes the clock
//! the ROM is told true again. probe-rs' `clk` argument is ignored. The IRC is +-1 %
//! (hardware-facts 7); OpenOCD's LPC17xx driver passes the same 4000 kHz after reset.
//! UNCONFIRMED (no hardware here): programming and erase results at this clock on a real part.
//!
//! **Memory map.** After a reset-and-halt the core stops in the boot ROM with MEMMAP = 0,
//! where the boot ROM's vectors hide the first 64 bytes of the flash; `Init` sets MEMMAP = 1
//! (user flash at 0), so reads after programming see the flash. `Verify` uses the ROM's
//! compare (56); UNCONFIRMED (no hardware here): that compare covers the first 64 bytes of
//! sector 0 like any other once MEMMAP = 1.
//!
//! **Interrupts** are masked in `Init` (PRIMASK): the ROM must not be interrupted while the
//! flash is busy. No reset happens between the entry points, so the mask stays.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(not(target_os = "none"))]
fn main() {}

#[cfg(target_os = "none")]
mod chip {
    use core::panic::PanicInfo;
    use flash_algo::{FlashAlgo, Staging};
    use lpc17xx_iap::rom::Rom;

    /// The CPU clock after `Init`: the internal RC oscillator, no PLL.
    const CCLK_KHZ: u32 = 4_000;
    /// Whether ProgramPage may write a CRP lock value (feature `allow-crp-lock`).
    const ALLOW_CRP_LOCK: bool = cfg!(feature = "allow-crp-lock");

    // System control registers (UM10360 chapters 3 and 4).
    const MEMMAP: *mut u32 = 0x400F_C040 as *mut u32;
    const PLL0CON: *mut u32 = 0x400F_C080 as *mut u32;
    const PLL0STAT: *const u32 = 0x400F_C088 as *const u32;
    const PLL0FEED: *mut u32 = 0x400F_C08C as *mut u32;
    const CCLKCFG: *mut u32 = 0x400F_C104 as *mut u32;
    const CLKSRCSEL: *mut u32 = 0x400F_C10C as *mut u32;
    const PLL0STAT_PLLE: u32 = 1 << 24;
    const PLL0STAT_PLLC: u32 = 1 << 25;
    const PLL0CON_ENABLE: u32 = 1;
    const MEMMAP_USER_FLASH: u32 = 1;

    fn algo() -> FlashAlgo<Rom> {
        FlashAlgo::new(Rom, CCLK_KHZ, ALLOW_CRP_LOCK)
    }

    fn code(r: Result<(), flash_algo::Error>) -> u32 {
        match r {
            Ok(()) => 0,
            Err(e) => e.code(),
        }
    }

    fn pll0_feed() {
        // SAFETY: PLL0FEED accepts any value; 0xAA then 0x55 commits PLL0CON.
        unsafe {
            PLL0FEED.write_volatile(0xAA);
            PLL0FEED.write_volatile(0x55);
        }
    }

    /// CPU on the IRC, PLL0 off, divide by 1 (UM10360 4.5.13 steps 1 to 4).
    fn run_from_irc() {
        // SAFETY: documented system control registers of the LPC17xx, written in the order
        // the user manual prescribes; the algorithm runs from RAM, so the flash timing
        // (FLASHCFG, any value is safe at 4 MHz) does not matter.
        unsafe {
            let stat = PLL0STAT.read_volatile();
            if stat & PLL0STAT_PLLC != 0 {
                PLL0CON.write_volatile(PLL0CON_ENABLE); // disconnect, stay enabled
                pll0_feed();
            }
            if stat & PLL0STAT_PLLE != 0 {
                PLL0CON.write_volatile(0); // disable
                pll0_feed();
            }
            CCLKCFG.write_volatile(0);
            CLKSRCSEL.write_volatile(0); // internal RC oscillator
        }
    }

    /// Init(adr, clk, fnc): interrupts off, user flash at 0, CPU on the IRC, part check.
    #[no_mangle]
    pub extern "C" fn Init(_adr: u32, _clk: u32, _fnc: u32) -> u32 {
        // SAFETY: masking interrupts and writing MEMMAP have no memory-safety effect on this
        // program; MEMMAP = 1 maps the user flash at 0 (UM10360 3.4).
        unsafe {
            core::arch::asm!("cpsid i", options(nomem, nostack, preserves_flags));
            MEMMAP.write_volatile(MEMMAP_USER_FLASH);
        }
        run_from_irc();
        code(algo().init())
    }

    /// UnInit(fnc): nothing to undo; the firmware sets its clocks after the reset.
    #[no_mangle]
    pub extern "C" fn UnInit(_fnc: u32) -> u32 {
        0
    }

    /// EraseSector(adr): `adr` is the first address of a sector.
    #[no_mangle]
    pub extern "C" fn EraseSector(adr: u32) -> u32 {
        code(algo().erase_sector(adr))
    }

    /// EraseChip(): sectors 0..=17.
    #[no_mangle]
    pub extern "C" fn EraseChip() -> u32 {
        code(algo().erase_chip())
    }

    /// The `sz` bytes probe-rs put at `buf`.
    ///
    /// SAFETY: the caller (probe-rs) passes one of its page buffers in RAM, at least `sz`
    /// bytes long, that nothing else touches while the entry point runs.
    unsafe fn buffer<'a>(buf: *const u8, sz: u32) -> &'a [u8] {
        if buf.is_null() || sz == 0 {
            return &[];
        }
        core::slice::from_raw_parts(buf, sz as usize)
    }

    /// ProgramPage(adr, sz, buf).
    #[no_mangle]
    pub extern "C" fn ProgramPage(adr: u32, sz: u32, buf: *const u8) -> u32 {
        // SAFETY: see `buffer`.
        let data = unsafe { buffer(buf, sz) };
        let mut staging = Staging::default();
        let staging_addr = &staging as *const Staging as u32;
        code(algo().program_page(adr, data, buf as u32, &mut staging, staging_addr))
    }

    /// Verify(adr, sz, buf): `adr + sz` when equal, else the first differing address.
    #[no_mangle]
    pub extern "C" fn Verify(adr: u32, sz: u32, buf: *const u8) -> u32 {
        // SAFETY: see `buffer`.
        let data = unsafe { buffer(buf, sz) };
        algo().verify(adr, data, buf as u32)
    }

    #[panic_handler]
    fn panic(_: &PanicInfo) -> ! {
        // The library does not panic; should it, stop where probe-rs sees a breakpoint.
        loop {
            // SAFETY: a breakpoint has no memory effect.
            unsafe { core::arch::asm!("bkpt #0") };
        }
    }
}
