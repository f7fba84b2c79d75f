//! The benchmark runner for QEMU's lm3s6965evb (Cortex-M3): runs each hot path of
//! [`bench_cm3`] between two marker calls and exits through semihosting.
//!
//! `cargo xtask bench` builds it for thumbv7m-none-eabi and runs
//! `qemu-system-arm -M lm3s6965evb -cpu cortex-m3 -icount shift=0 -semihosting` with the
//! project's plugin (`xtask/qemu-plugin/insn_count.c`), which counts the instructions executed
//! from the entry of [`bench_begin`] to the entry of [`bench_end`]. Each region's name is
//! printed (semihosting SYS_WRITE0) in the same order, so the plugin's counts pair with them.
//! An empty region (`baseline`) gives the markers' own instructions, which xtask subtracts.
//! On the host this is a stub: the scenarios are tested in the library.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!("bench-cm3 runs on a Cortex-M3 under QEMU: use `cargo xtask bench`");
}

#[cfg(target_os = "none")]
mod runner {
    use bench_cm3::{drain, driver_port, push_one, queue_scan, CheckFailed, DmaRig, Rig, RING};
    use core::hint::black_box;
    use firmware::io::analog::adc_dma::HalfCounter;
    use firmware::io::analog::outputs::DacAction;
    use firmware::io::analog::sampler::{PublishMode, SampleRing, Sampler};

    /// Semihosting operations (ARM semihosting specification).
    const SYS_WRITE0: u32 = 0x04;
    const SYS_EXIT: u32 = 0x18;
    /// ADP_Stopped_ApplicationExit / ADP_Stopped_RunTimeErrorUnknown.
    const EXIT_OK: u32 = 0x20026;
    const EXIT_FAILED: u32 = 0x20023;
    /// Measured runs per path (after one unmeasured warm-up run); all must count the same.
    const REPEAT: u32 = 3;

    fn print(parts: &[&str]) {
        let mut buf = [0u8; 160];
        let mut n = 0;
        for p in parts {
            for &b in p.as_bytes() {
                if n < buf.len() - 2 {
                    buf[n] = b;
                    n += 1;
                }
            }
        }
        buf[n] = b'\n';
        // SAFETY: SYS_WRITE0 reads the NUL-terminated string at the address (the rest of buf is 0).
        unsafe { cortex_m::asm::semihosting_syscall(SYS_WRITE0, buf.as_ptr() as u32) };
    }

    fn exit(code: u32) -> ! {
        loop {
            // SAFETY: SYS_EXIT with a reason code in r1 (32-bit semihosting: the value itself).
            unsafe { cortex_m::asm::semihosting_syscall(SYS_EXIT, code) };
        }
    }

    /// Start of a measured region (the plugin watches this address).
    #[no_mangle]
    #[inline(never)]
    pub extern "C" fn bench_begin() {
        // Distinct bodies: identical functions would be merged into one address.
        black_box(0xB1u32);
    }

    /// End of a measured region.
    #[no_mangle]
    #[inline(never)]
    pub extern "C" fn bench_end() {
        black_box(0xE2u32);
    }

    #[inline(always)]
    fn measure<R>(name: &str, f: impl FnOnce() -> R) -> R {
        print(&["region ", name]);
        // Called through opaque pointers: never inlined, so the plugin sees their entries.
        let (begin, end) =
            black_box((bench_begin as extern "C" fn(), bench_end as extern "C" fn()));
        begin();
        let r = black_box(f());
        end();
        r
    }

    fn check(ok: bool, what: &'static str) -> Result<(), CheckFailed> {
        if ok {
            Ok(())
        } else {
            Err(CheckFailed(what))
        }
    }

    /// The GPDMA interrupt's counter (a static in `hw::adc_dma` too).
    static IRQ_HALVES: HalfCounter = HalfCounter::new();

    fn run() -> Result<(), CheckFailed> {
        // DC SYNC0 at the module's shortest cycle, the cycle of the bench's bus-cost run.
        let mut rig = Rig::new(firmware::products::analog_io::sync::MIN_CYCLE_TIME_NS)?;
        for _ in 0..4 {
            rig.cycle()?;
        }
        let mut ring = SampleRing::<RING>::new();
        let (mut producer, mut consumer) = ring.split();
        let mut sampler = Sampler::new(PublishMode::Latest);
        let mut driver = driver_port();
        let mut dma = DmaRig::new();
        for rep in 0..=REPEAT {
            // The warm-up run (rep 0) is not printed as a region: same code, unmeasured.
            let m = rep > 0;
            let name = |n: &'static str| if m { n } else { "-" };

            measure(name("baseline"), || ());

            rig.master_outputs();
            let out = measure(name("pdi_outputs"), || rig.irq())?;
            check(
                !out.apply_outputs,
                "pdi_outputs: DC outputs must wait for SYNC0",
            )?;
            let pair = measure(name("dac_preload"), || rig.preload());
            check(pair.is_some(), "dac_preload: no fresh pair")?;
            let action = measure(name("sync0_ldac"), || rig.sync0_latch());
            check(
                matches!(action, DacAction::PulseLdac(_)),
                "sync0_ldac: the preloaded pair must only need LDAC",
            )?;
            measure(name("sync0_record"), || rig.sync0_record());
            let writes = rig.esc.writes;
            let scan = rig.adc_scan();
            measure(name("pdi_inputs"), || rig.poll())?;
            check(rig.esc.writes > writes, "pdi_inputs: SM3 not written")?;
            rig.check_published(&scan)?;
            rig.check_op()?;

            rig.master_sdo(0x40, 0x1018, 2, [0; 4])?;
            measure(name("sdo_upload"), || rig.irq())?;
            check(
                rig.master_sdo_reply()?.0 == 0x43,
                "sdo_upload: no 4-byte reply",
            )?;
            rig.master_sdo(0x2F, 0x6443, 1, [1, 0, 0, 0])?;
            measure(name("sdo_download"), || rig.irq())?;
            check(
                rig.master_sdo_reply()?.0 == 0x60,
                "sdo_download: not acknowledged",
            )?;

            let pushed = measure(name("sample_push"), || push_one(&mut producer, rep));
            check(pushed, "sample_push: ring full")?;
            check(drain(&mut consumer, &mut sampler) == 1, "sample_push: lost")?;
            queue_scan(&mut producer)?;
            let moved = measure(name("sampler_drain"), || drain(&mut consumer, &mut sampler));
            check(moved == 8, "sampler_drain: not one scan")?;

            // The GPDMA path: one scan in the ring, drained by the PDI task; the interrupt's
            // work per half ring.
            dma.dma_writes_scan();
            let scans = measure(name("dma_scan_drain"), || dma.drain(&mut sampler))?;
            check(scans == 1, "dma_scan_drain: not one scan")?;
            // (A counter of its own, a static like the firmware's: the rig's count must keep
            // matching its ring.)
            let halves = IRQ_HALVES.get();
            measure(name("dma_half_irq"), || IRQ_HALVES.on_terminal_count());
            check(IRQ_HALVES.get() == halves + 1, "dma_half_irq: not counted")?;

            // The register-file ESC's own cost per access (a stand-in, not firmware code):
            // a 4-byte read and a 16-byte SM3 write, as in the cycle.
            let mut word = [0u8; 4];
            let r = measure(name("esc_read4"), || {
                rig.esc.driver().read(0x0440, &mut word)
            });
            check(r.is_ok(), "esc_read4 failed")?;
            let w = measure(name("esc_write16"), || {
                rig.esc.driver().write(0x1180, &[0u8; 16])
            });
            check(w.is_ok(), "esc_write16 failed")?;
            // The same accesses through the et1100 SPI driver (over an SPI that clocks
            // nothing): what replaces the stand-in's cost on the board.
            let r = measure(name("driver_read4"), || driver.read(0x0440, &mut word));
            check(r.is_ok(), "driver_read4 failed")?;
            let w = measure(name("driver_write16"), || driver.write(0x1180, &[0u8; 16]));
            check(w.is_ok(), "driver_write16 failed")?;
            // The event sample of every cycle (SPI: the 2-byte NOP), both ways.
            let e = measure(name("esc_nop"), || rig.esc.driver().low_events());
            check(e.is_ok(), "esc_nop failed")?;
            let e = measure(name("driver_nop"), || driver.low_events());
            check(e.is_ok(), "driver_nop failed")?;
        }
        Ok(())
    }

    /// Called by `Reset` after .data/.bss are initialised.
    #[no_mangle]
    pub extern "C" fn bench_main() -> ! {
        match run() {
            Ok(()) => {
                print(&["done"]);
                exit(EXIT_OK)
            }
            Err(CheckFailed(what)) => {
                print(&["check failed: ", what]);
                exit(EXIT_FAILED)
            }
        }
    }

    #[panic_handler]
    fn panic(_: &core::panic::PanicInfo) -> ! {
        print(&["panic"]);
        exit(EXIT_FAILED)
    }

    extern "C" fn fault() {
        print(&["fault"]);
        exit(EXIT_FAILED)
    }

    extern "C" {
        fn Reset() -> !;
    }

    /// Word 1 of the vector table (word 0, the initial stack pointer, is in the linker script).
    #[link_section = ".vector_table.reset_vector"]
    #[no_mangle]
    #[used]
    static RESET_VECTOR: unsafe extern "C" fn() -> ! = Reset;

    /// NMI .. SysTick: every exception is a failure of the benchmark.
    #[link_section = ".vector_table.exceptions"]
    #[no_mangle]
    #[used]
    static EXCEPTIONS: [extern "C" fn(); 14] = [fault; 14];

    // Reset: zero .bss, copy .data from flash, call bench_main (before any Rust code runs,
    // so no Rust code sees uninitialised statics).
    core::arch::global_asm!(
        ".section .text.Reset, \"ax\"",
        ".global Reset",
        ".type Reset, %function",
        ".thumb_func",
        "Reset:",
        "  ldr r0, =_sbss",
        "  ldr r1, =_ebss",
        "  movs r2, #0",
        "1:",
        "  cmp r0, r1",
        "  beq 2f",
        "  str r2, [r0], #4",
        "  b 1b",
        "2:",
        "  ldr r0, =_sdata",
        "  ldr r1, =_edata",
        "  ldr r2, =_sidata",
        "3:",
        "  cmp r0, r1",
        "  beq 4f",
        "  ldr r3, [r2], #4",
        "  str r3, [r0], #4",
        "  b 3b",
        "4:",
        "  bl bench_main",
        "  b .",
        ".ltorg",
    );
}
