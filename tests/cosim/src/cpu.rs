//! The Cortex-M3 core on unicorn (Thumb-2 execution) with the ARMv7-M exception model done
//! here, since unicorn's M-profile mode takes no exceptions (cosim-notes): stacking of the
//! 8-word frame (with the STKALIGN pad), EXC_RETURN in LR, IPSR, the vector fetch through
//! VTOR, exception return caught where unicorn reports it (interrupt number 8 with PC =
//! EXC_RETURN), tail-chaining, preemption by priority against PRIMASK, BASEPRI and FAULTMASK,
//! WFI as sleep until the next event.
//!
//! Time: every block adds its instructions x CPI ([`crate::machine::CPI_NUM`]) before it
//! runs; peripherals' events due by then are served in the block hook (without leaving the
//! engine), each at its own time, which also stops the engine at the slice's end or when an
//! exception becomes takeable. An event inside a block's time that makes an exception
//! takeable stops the block before it runs, so the exception is entered at the event's time
//! as on the core (never inside an IT block); the block runs after the handler.

use crate::ahb_sram;
use crate::chip::{Chip, Span};
use crate::iap;
use crate::image::Image;
use crate::machine::{Machine, ResetCause, Stop, ENTRY_CYCLES, RETURN_CYCLES, TAIL_CHAIN_CYCLES};
use crate::rtt::Memory;
use std::cell::RefCell;
use std::fmt;
use std::rc::Rc;
use unicorn_engine::{Arch, HookType, MemType, Mode, Prot, RegisterARM, Unicorn};

/// The machine as the engine's hooks reach it.
pub type Shared = Rc<RefCell<Machine>>;

/// The engine with the machine as its data.
pub type Engine = Unicorn<'static, Shared>;

/// The LPC1754's local SRAM (16 KB).
pub const SRAM: (u32, u32) = (0x1000_0000, 0x4000);
/// The pattern painted over the stack to find its deepest use.
pub const STACK_PAINT: u32 = 0xC5C5_C5C5;

/// The engine's memory, for the log reader.
pub(crate) struct EngineMem<'a, 'b>(pub(crate) &'a mut Unicorn<'b, Shared>);

impl Memory for EngineMem<'_, '_> {
    fn read(&mut self, addr: u32, buf: &mut [u8]) -> bool {
        self.0.mem_read(u64::from(addr), buf).is_ok()
    }
    fn write(&mut self, addr: u32, data: &[u8]) -> bool {
        let sram = self.0.get_data().borrow().chip.sram();
        sram.contains(addr, data.len() as u32) && self.0.mem_write(u64::from(addr), data).is_ok()
    }
}

/// A fault of the core (the run reports it and the core stops).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Fault {
    /// What happened.
    pub cause: String,
    /// PC at the fault.
    pub pc: u32,
    /// The function at PC, if known.
    pub function: Option<String>,
    /// SP and the 16 words above it.
    pub sp: u32,
    /// The stack words.
    pub stack: Vec<u32>,
    /// Virtual time (ns).
    pub time_ns: u64,
}

impl fmt::Display for Fault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "HardFault: {} at PC {:#010x}", self.cause, self.pc)?;
        if let Some(func) = &self.function {
            write!(f, " ({func})")?;
        }
        write!(
            f,
            ", {:.6} s; SP {:#010x}, stack:",
            self.time_ns as f64 * 1e-9,
            self.sp
        )?;
        for (i, w) in self.stack.iter().enumerate() {
            if i % 8 == 0 {
                write!(f, "\n  {:#010x}:", self.sp + 4 * i as u32)?;
            }
            write!(f, " {w:08x}")?;
        }
        Ok(())
    }
}

fn reg(uc: &Unicorn<'_, Shared>, r: RegisterARM) -> u32 {
    uc.reg_read(r).unwrap_or(0) as u32
}

fn set(uc: &mut Unicorn<'_, Shared>, r: RegisterARM, v: u32) {
    let _ = uc.reg_write(r, u64::from(v));
}

/// Rebuilds unicorn's cached translation flags after an IPSR change (the handler-mode flag
/// decides whether `bx lr` with EXC_RETURN is an exception return; unicorn 2.1.5 does not
/// rebuild them on an IPSR/XPSR write, but does on an APSR_NZCV write).
fn rebuild_flags(uc: &mut Unicorn<'_, Shared>) {
    let apsr = reg(uc, RegisterARM::APSR);
    set(uc, RegisterARM::APSR_NZCV, apsr & 0xF000_0000);
}

fn masks(uc: &Unicorn<'_, Shared>) -> (bool, u8, bool) {
    (
        reg(uc, RegisterARM::PRIMASK) & 1 != 0,
        reg(uc, RegisterARM::BASEPRI) as u8,
        reg(uc, RegisterARM::FAULTMASK) & 1 != 0,
    )
}

fn read_word(uc: &Unicorn<'_, Shared>, addr: u32) -> Option<u32> {
    let mut b = [0u8; 4];
    uc.mem_read(u64::from(addr), &mut b).ok()?;
    Some(u32::from_le_bytes(b))
}

/// The core.
pub struct Core {
    /// The engine.
    pub uc: Engine,
    /// The machine.
    pub machine: Shared,
    /// Asleep in WFI.
    pub sleeping: bool,
    /// The fault that stopped the core.
    pub fault: Option<Fault>,
    /// Resets taken (cause, time ns).
    pub resets: Vec<(ResetCause, u64)>,
    image: Rc<Image>,
}

impl Core {
    /// The engine with the image in flash, RAM, the peripheral bus and the hooks; the core
    /// at its reset vector.
    pub fn new(image: Rc<Image>, machine: Shared) -> Result<Self, String> {
        fn err(what: &'static str) -> impl Fn(unicorn_engine::uc_error) -> String {
            move |e| format!("unicorn: {what}: {e:?}")
        }
        let mut uc = Unicorn::new_with_data(Arch::ARM, Mode::THUMB | Mode::MCLASS, machine.clone())
            .map_err(err("open"))?;
        if image.chip == Chip::Stm32f103 {
            crate::stm32::map_memory(&mut uc, &image, &machine)?;
        } else {
            Self::map_lpc1754(&mut uc, &image, &machine)?;
        }
        uc.add_block_hook(1, 0, block_hook)
            .map_err(err("block hook"))?;
        if image.app_vectors != 0 {
            // The stack is measured from the application's start: the bootloader before it
            // runs on the same RAM.
            let entry = u64::from(image.app_entry());
            let (floor, top) = (image.stack_floor, image.initial_sp());
            let sram = image.chip.sram();
            uc.add_code_hook(entry, entry, move |uc: &mut Unicorn<'_, Shared>, _, _| {
                paint(uc, sram, floor, top);
            })
            .map_err(err("application entry hook"))?;
        }
        uc.add_mem_hook(
            HookType::MEM_UNMAPPED | HookType::MEM_PROT,
            1,
            0,
            |uc: &mut Unicorn<'_, Shared>, kind: MemType, addr: u64, size: usize, value: i64| {
                let what = match kind {
                    MemType::READ_UNMAPPED => format!("read of unmapped {addr:#010x} ({size} B)"),
                    MemType::WRITE_UNMAPPED => {
                        format!("write of {value:#x} to unmapped {addr:#010x} ({size} B)")
                    }
                    MemType::FETCH_UNMAPPED | MemType::FETCH_PROT => {
                        if (0x1FFF_0000..0x2000_0000).contains(&addr) {
                            format!("call into the boot ROM at {addr:#010x} (IAP/ROM not modelled)")
                        } else {
                            format!("instruction fetch from {addr:#010x}")
                        }
                    }
                    MemType::WRITE_PROT => format!("write of {value:#x} to flash at {addr:#010x}"),
                    other => format!("{other:?} at {addr:#010x}"),
                };
                let m = uc.get_data().clone();
                m.borrow_mut().stop = Some(Stop::Fault(what));
                false
            },
        )
        .map_err(err("memory hook"))?;
        uc.add_intr_hook(intr_hook).map_err(err("interrupt hook"))?;
        let mut core = Self {
            uc,
            machine,
            sleeping: false,
            fault: None,
            resets: Vec::new(),
            image,
        };
        core.paint_stack();
        core.reset_core()?;
        Ok(core)
    }

    /// The LPC1754's memory: flash at 0, the local SRAM, the AHB SRAM (the machine's), the
    /// APB slots, FIO, GPDMA, SCS, and the IAP ROM's entry.
    fn map_lpc1754(uc: &mut Engine, image: &Image, machine: &Shared) -> Result<(), String> {
        fn err(what: &'static str) -> impl Fn(unicorn_engine::uc_error) -> String {
            move |e| format!("unicorn: {what}: {e:?}")
        }
        uc.mem_map(0, image.flash.len() as u64, Prot::READ | Prot::EXEC)
            .map_err(err("flash"))?;
        uc.mem_write(0, &image.flash)
            .map_err(err("flash contents"))?;
        if let Some(l) = machine.borrow_mut().lpc17xx_mut() {
            l.flash.load(0, &image.flash);
        }
        uc.mem_map(u64::from(SRAM.0), u64::from(SRAM.1), Prot::ALL)
            .map_err(err("SRAM"))?;
        // The AHB SRAM belongs to the machine (the GPDMA's memory, watched for samples).
        uc.mmio_map(
            u64::from(ahb_sram::BASE),
            u64::from(ahb_sram::SIZE),
            Some(|uc: &mut Unicorn<'_, Shared>, off: u64, size: usize| {
                let m = uc.get_data().clone();
                let v = m.borrow_mut().ahb_read(ahb_sram::BASE + off as u32, size);
                u64::from(v)
            }),
            Some(
                |uc: &mut Unicorn<'_, Shared>, off: u64, size: usize, v: u64| {
                    let m = uc.get_data().clone();
                    m.borrow_mut()
                        .ahb_write(ahb_sram::BASE + off as u32, size, v as u32);
                },
            ),
        )
        .map_err(err("AHB SRAM"))?;
        // One slot per APB peripheral (16 KB each), the FIO block, the GPDMA, the SCS.
        let mut slots: Vec<(u32, u32)> = (0..64)
            .map(|i| (0x4000_0000 + i * 0x4000, 0x4000))
            .collect();
        slots.push((0x2009_C000, 0x4000));
        slots.push((0x5000_4000, 0x1000));
        slots.push((0xE000_E000, 0x1000));
        for (base, size) in slots {
            uc.mmio_map(
                u64::from(base),
                u64::from(size),
                Some(move |uc: &mut Unicorn<'_, Shared>, off: u64, size: usize| {
                    let m = uc.get_data().clone();
                    let v = m.borrow_mut().cpu_read(base + off as u32, size);
                    u64::from(v)
                }),
                Some(
                    move |uc: &mut Unicorn<'_, Shared>, off: u64, size: usize, v: u64| {
                        let m = uc.get_data().clone();
                        m.borrow_mut().cpu_write(base + off as u32, size, v as u32);
                    },
                ),
            )
            .map_err(err("peripheral map"))?;
        }
        iap::map(uc)?;
        Ok(())
    }

    fn paint_stack(&mut self) {
        paint(
            &mut self.uc,
            self.image.chip.sram(),
            self.image.stack_floor,
            self.image.initial_sp(),
        );
    }

    /// The image.
    pub fn image(&self) -> &Image {
        &self.image
    }

    /// Deepest stack use since power-on: bytes below the initial SP that are no longer the
    /// paint.
    pub fn stack_high_water(&self) -> u32 {
        let (floor, top) = (self.image.stack_floor, self.image.initial_sp());
        if !stack_in_sram(self.image.chip.sram(), floor, top) {
            return 0;
        }
        let n = (top - floor) as usize;
        let mut buf = vec![0u8; n];
        if self.uc.mem_read(u64::from(floor), &mut buf).is_err() {
            return 0;
        }
        let first_used = buf
            .chunks(4)
            .position(|w| w != STACK_PAINT.to_le_bytes())
            .unwrap_or(n / 4);
        (n - 4 * first_used) as u32
    }

    /// Stack size: the local SRAM from the stack's floor up to the initial SP.
    pub fn stack_size(&self) -> u32 {
        self.image
            .initial_sp()
            .saturating_sub(self.image.stack_floor)
    }

    fn reset_core(&mut self) -> Result<(), String> {
        let sp = self.image.reset_sp();
        let pc = self.image.reset_vector();
        let uc = &mut self.uc;
        set(uc, RegisterARM::CONTROL, 0);
        set(uc, RegisterARM::PRIMASK, 0);
        set(uc, RegisterARM::BASEPRI, 0);
        set(uc, RegisterARM::FAULTMASK, 0);
        set(uc, RegisterARM::XPSR, 1 << 24);
        rebuild_flags(uc);
        set(uc, RegisterARM::MSP, sp);
        set(uc, RegisterARM::SP, sp);
        set(uc, RegisterARM::LR, 0xFFFF_FFFF);
        set(uc, RegisterARM::PC, pc | 1);
        self.sleeping = false;
        if pc & 1 == 0 {
            return Err(format!("reset vector {pc:#010x} is not a Thumb address"));
        }
        Ok(())
    }

    /// A chip reset (watchdog, SYSRESETREQ).
    pub fn reset(&mut self, cause: ResetCause) {
        let now = {
            let mut m = self.machine.borrow_mut();
            m.reset(cause);
            m.now_ns()
        };
        self.resets.push((cause, now));
        if let Err(e) = self.reset_core() {
            self.record_fault(e);
        }
    }

    fn record_fault(&mut self, cause: String) {
        let pc = reg(&self.uc, RegisterARM::PC);
        let sp = reg(&self.uc, RegisterARM::SP);
        let stack = (0..16)
            .map(|i| read_word(&self.uc, sp + 4 * i).unwrap_or(0))
            .collect();
        let function = self
            .image
            .symbolize(pc)
            .map(|(name, off)| format!("{name}+{off:#x}"));
        let time_ns = self.machine.borrow().now_ns();
        self.fault = Some(Fault {
            cause,
            pc,
            function,
            sp,
            stack,
            time_ns,
        });
    }

    /// Takes every exception that preempts now (stacking, vector fetch).
    fn take_exceptions(&mut self) {
        for _ in 0..8 {
            let (primask, basepri, faultmask) = masks(&self.uc);
            let Some(e) = self
                .machine
                .borrow()
                .scs
                .preempting(primask, basepri, faultmask)
            else {
                return;
            };
            self.sleeping = false;
            if let Err(cause) = self.enter(e) {
                self.record_fault(cause);
                return;
            }
        }
    }

    fn enter(&mut self, e: u32) -> Result<(), String> {
        let uc = &mut self.uc;
        let in_handler = reg(uc, RegisterARM::IPSR) & 0x1FF != 0;
        let psp = !in_handler && reg(uc, RegisterARM::CONTROL) & 2 != 0;
        let sp_before = reg(uc, RegisterARM::SP);
        let mut sp = sp_before;
        let mut xpsr = reg(uc, RegisterARM::XPSR);
        let align = self.machine.borrow().scs.stack_align_8();
        if align && sp & 4 != 0 {
            sp -= 4;
            xpsr |= 1 << 9;
        } else {
            xpsr &= !(1 << 9);
        }
        sp -= 32;
        let frame = [
            reg(uc, RegisterARM::R0),
            reg(uc, RegisterARM::R1),
            reg(uc, RegisterARM::R2),
            reg(uc, RegisterARM::R3),
            reg(uc, RegisterARM::R12),
            reg(uc, RegisterARM::LR),
            reg(uc, RegisterARM::PC) & !1,
            xpsr,
        ];
        let bytes: Vec<u8> = frame.iter().flat_map(|w| w.to_le_bytes()).collect();
        uc.mem_write(u64::from(sp), &bytes).map_err(|_| {
            format!("stacking for exception {e} to {sp:#010x} failed (stack overflow?)")
        })?;
        set(uc, RegisterARM::SP, sp);
        let exc_return = if in_handler {
            0xFFFF_FFF1
        } else if psp {
            0xFFFF_FFFD
        } else {
            0xFFFF_FFF9
        };
        let vector_at = {
            let mut m = self.machine.borrow_mut();
            let (cycle, now) = (m.cycles, m.now_ns());
            m.profile.entered(e, cycle, now, sp_before, sp);
            m.add_cycles(ENTRY_CYCLES);
            m.scs.activate(e)
        };
        let handler = read_word(uc, vector_at)
            .ok_or_else(|| format!("vector of exception {e} at {vector_at:#010x} unreadable"))?;
        if handler & 1 == 0 {
            return Err(format!(
                "vector of exception {e} is {handler:#010x}, not a Thumb address"
            ));
        }
        set(uc, RegisterARM::IPSR, e);
        set(uc, RegisterARM::EPSR, 1 << 24);
        rebuild_flags(uc);
        set(uc, RegisterARM::LR, exc_return);
        set(uc, RegisterARM::PC, handler);
        Ok(())
    }

    /// The virtual time the core must run at next: now while it runs or has an interrupt to
    /// take, else (asleep in WFI, or faulted) the machine's next event.
    pub fn next_wake_ns(&self) -> u64 {
        let m = self.machine.borrow();
        let (_, basepri, faultmask) = masks(&self.uc);
        let runs = !self.sleeping || m.scs.wakes_from_wfi(basepri, faultmask);
        if runs && self.fault.is_none() {
            m.now_ns()
        } else {
            m.next_event_ns().max(m.now_ns())
        }
    }

    /// Asleep in WFI: sleeps on up to `t_ns`, serving the chip's own events on the way, and
    /// stops at the first that wakes the core (or resets the chip). The board's inputs are
    /// not looked at: what changed there is seen from the time reached on. Returns that time.
    pub fn idle_until(&mut self, t_ns: u64) -> u64 {
        loop {
            let now = self.machine.borrow().now_ns();
            if now >= t_ns || !self.sleeping || self.fault.is_some() {
                return now;
            }
            let (_, basepri, faultmask) = masks(&self.uc);
            let mut m = self.machine.borrow_mut();
            if m.stop.is_some() || m.scs.wakes_from_wfi(basepri, faultmask) {
                return now;
            }
            let next = m.next_event_ns().min(t_ns);
            m.sleep_until(next);
            m.service_due();
        }
    }

    /// Runs until virtual time `t_ns` exactly (or a fault): something outside happens then
    /// (a SYNC0 edge) that the core must see at its time, not at the end of the block that
    /// reached it (see [`crate::machine::Cortex::exact_deadline`]).
    pub fn run_until_exactly(&mut self, t_ns: u64) {
        self.machine.borrow_mut().exact_deadline = true;
        self.run_until(t_ns);
        self.machine.borrow_mut().exact_deadline = false;
    }

    /// Runs until virtual time `t_ns` (or a fault): the slice ends with the first block that
    /// reaches it.
    pub fn run_until(&mut self, t_ns: u64) {
        for _ in 0..10_000_000u64 {
            {
                let mut m = self.machine.borrow_mut();
                m.refresh_inputs();
                m.service_due();
            }
            let stop = self.machine.borrow_mut().stop.take();
            match stop {
                Some(Stop::Reset(cause)) => {
                    self.reset(cause);
                    continue;
                }
                Some(Stop::Fault(cause)) => {
                    self.record_fault(cause);
                }
                _ => {}
            }
            let now = self.machine.borrow().now_ns();
            if now >= t_ns {
                return;
            }
            if self.fault.is_some() {
                // A faulted core sits in its fault loop; the peripherals (and the
                // watchdog) go on.
                let next = self.machine.borrow().next_event_ns().min(t_ns);
                self.machine.borrow_mut().sleep_until(next);
                continue;
            }
            self.take_exceptions();
            if self.sleeping {
                let (_, basepri, faultmask) = masks(&self.uc);
                if self.machine.borrow().scs.wakes_from_wfi(basepri, faultmask) {
                    self.sleeping = false;
                    continue;
                }
                let next = self.machine.borrow().next_event_ns().min(t_ns);
                self.machine.borrow_mut().sleep_until(next);
                continue;
            }
            self.machine.borrow_mut().deadline_ns = t_ns;
            let pc = reg(&self.uc, RegisterARM::PC);
            let result = self.uc.emu_start(u64::from(pc | 1), 0, 0, 0);
            let stop = self.machine.borrow_mut().stop.take();
            match (result, stop) {
                (_, Some(Stop::Fault(cause))) => self.record_fault(cause),
                (_, Some(Stop::Reset(cause))) => self.reset(cause),
                (Ok(()), Some(Stop::Deadline | Stop::Preempt)) => {}
                (Ok(()), None) => {
                    let pc = reg(&self.uc, RegisterARM::PC);
                    let mut b = [0u8; 2];
                    let wfi = self
                        .uc
                        .mem_read(u64::from(pc.wrapping_sub(2)), &mut b)
                        .is_ok()
                        && u16::from_le_bytes(b) == 0xBF30;
                    if wfi {
                        self.sleeping = true;
                    } else {
                        self.record_fault(format!("the engine stopped at {pc:#010x}"));
                    }
                }
                (Err(e), _) => self.record_fault(format!("unicorn: {e:?}")),
            }
        }
        self.record_fault("the run loop did not reach the slice's end".into());
    }

    /// Exception return (from the interrupt hook).
    fn exception_return(uc: &mut Unicorn<'_, Shared>, exc_return: u32) -> Result<(), String> {
        let m = uc.get_data().clone();
        let (primask, basepri, faultmask) = masks(uc);
        let sp = reg(uc, RegisterARM::SP);
        let chained = {
            let mut m = m.borrow_mut();
            if m.scs.current() == 0 {
                return Err(format!("exception return ({exc_return:#x}) in thread mode"));
            }
            m.scs.deactivate();
            m.check_preempt = m.scs.any_pending();
            let next = m.scs.preempting(primask, basepri, faultmask);
            if let Some(e) = next {
                // The frame stays: the chained handler starts where the returning one
                // started.
                let (cycle, now) = (m.cycles, m.now_ns());
                let sp_before = m.profile.returned(cycle).unwrap_or(sp);
                m.profile.entered(e, cycle, now, sp_before, sp);
                m.add_cycles(TAIL_CHAIN_CYCLES);
                Some((e, m.scs.activate(e)))
            } else {
                m.add_cycles(RETURN_CYCLES);
                let cycle = m.cycles;
                m.profile.returned(cycle);
                None
            }
        };
        if let Some((e, vector_at)) = chained {
            // Tail-chaining: the frame stays, the next handler runs with the same LR.
            let handler = read_word(uc, vector_at).unwrap_or(0);
            set(uc, RegisterARM::IPSR, e);
            rebuild_flags(uc);
            set(uc, RegisterARM::LR, exc_return | 1);
            set(uc, RegisterARM::PC, handler);
            return Ok(());
        }
        let to_thread = exc_return & 8 != 0;
        let use_psp = exc_return & 4 != 0;
        let sp = if use_psp {
            reg(uc, RegisterARM::PSP)
        } else {
            reg(uc, RegisterARM::MSP)
        };
        let mut b = [0u8; 32];
        uc.mem_read(u64::from(sp), &mut b)
            .map_err(|_| format!("unstacking from {sp:#010x} failed"))?;
        let w = |i: usize| u32::from_le_bytes(b[4 * i..4 * i + 4].try_into().expect("4 bytes"));
        let xpsr = w(7);
        if to_thread != (xpsr & 0x1FF == 0) {
            return Err(format!(
                "EXC_RETURN {exc_return:#x} does not match the stacked IPSR {}",
                xpsr & 0x1FF
            ));
        }
        if use_psp {
            set(uc, RegisterARM::CONTROL, reg(uc, RegisterARM::CONTROL) | 2);
        }
        set(uc, RegisterARM::XPSR, xpsr & !(1 << 9));
        rebuild_flags(uc);
        let new_sp = sp + 32 + if xpsr & (1 << 9) != 0 { 4 } else { 0 };
        set(uc, RegisterARM::SP, new_sp);
        set(uc, RegisterARM::R0, w(0));
        set(uc, RegisterARM::R1, w(1));
        set(uc, RegisterARM::R2, w(2));
        set(uc, RegisterARM::R3, w(3));
        set(uc, RegisterARM::R12, w(4));
        set(uc, RegisterARM::LR, w(5));
        set(uc, RegisterARM::PC, w(6) | 1);
        Ok(())
    }
}

/// Whether `floor..top` is a stack in the chip's SRAM.
fn stack_in_sram(sram: Span, floor: u32, top: u32) -> bool {
    top > floor && sram.contains(floor, top - floor)
}

/// Paints the SRAM from `floor` up to `top` (a stack) with [`STACK_PAINT`].
fn paint(uc: &mut Unicorn<'_, Shared>, sram: Span, floor: u32, top: u32) {
    if stack_in_sram(sram, floor, top) {
        let n = (top - floor) as usize;
        let bytes: Vec<u8> = STACK_PAINT
            .to_le_bytes()
            .iter()
            .copied()
            .cycle()
            .take(n)
            .collect();
        let _ = uc.mem_write(u64::from(floor), &bytes);
    }
}

fn block_hook(uc: &mut Unicorn<'_, Shared>, addr: u64, size: u32) {
    let machine = uc.get_data().clone();
    {
        let mut m = machine.borrow_mut();
        if m.stop.is_some() {
            let _ = uc.emu_stop();
            return;
        }
        if m.now_ns() >= m.deadline_ns {
            m.stop = Some(Stop::Deadline);
            let _ = uc.emu_stop();
            return;
        }
        if m.check_preempt {
            let (primask, basepri, faultmask) = masks(uc);
            if m.scs.preempting(primask, basepri, faultmask).is_some() {
                m.stop = Some(Stop::Preempt);
                let _ = uc.emu_stop();
                return;
            }
        }
    }
    let sp = reg(uc, RegisterARM::SP);
    let masks = masks(uc);
    let runs = machine.borrow_mut().run_block(
        addr as u32,
        size,
        sp,
        || uc.mem_read_as_vec(addr, size as usize).unwrap_or_default(),
        masks,
    );
    if !runs {
        // An event inside the block's time made an exception takeable (or stopped the core).
        let mut m = machine.borrow_mut();
        m.stop.get_or_insert(Stop::Preempt);
        let _ = uc.emu_stop();
        return;
    }
    // Only a block that runs carries out the IAP command: a block stopped above starts
    // again later, and the command must happen once.
    if addr == u64::from(iap::ENTRY) {
        iap::call(uc);
    }
    let mut m = machine.borrow_mut();
    if m.next_event_ns() <= m.now_ns() {
        m.service_due();
    }
}

fn intr_hook(uc: &mut Unicorn<'_, Shared>, intno: u32) {
    const EXCP_UDEF: u32 = 1;
    const EXCP_SWI: u32 = 2;
    const EXCP_BKPT: u32 = 7;
    const EXCP_EXCEPTION_EXIT: u32 = 8;
    let m = uc.get_data().clone();
    let result = match intno {
        EXCP_EXCEPTION_EXIT => {
            let exc_return = reg(uc, RegisterARM::PC) | 1;
            Core::exception_return(uc, exc_return)
        }
        EXCP_UDEF => Err("undefined instruction (UDF: panic-probe's halt, or a bad opcode)".into()),
        EXCP_BKPT => Err("BKPT without a debugger".into()),
        EXCP_SWI => Err("SVC (no SVCall handler is modelled)".into()),
        other => Err(format!("CPU exception {other} from the engine")),
    };
    if let Err(cause) = result {
        m.borrow_mut().stop = Some(Stop::Fault(cause));
        let _ = uc.emu_stop();
    }
}
