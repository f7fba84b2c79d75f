//! The module as shipped: the bootloader and the application on one CPU, one flash (the
//! `lpc17xx-iap` model, shared so a test can look at it) and the boot request word between
//! them, with the bootloader's reset sequence at every reset:
//!
//! - reset: [`firmware::platform::boot::install::startup`] on the flash (install a staged update,
//!   check the application slot), then the application ([`FirmwareCpu`]) or, if a boot
//!   request came or no valid application is there, the bootloader's slave
//!   ([`firmware::stacks::ethercat::boot_slave::BootSlave`] on the ESC through the same driver and SPI model);
//! - the application asks for the bootloader (a master's INIT -> BOOT,
//!   [`FirmwareCpu::bootloader_requested`]): request word set, reset;
//! - the bootloader's BOOT -> INIT (or PREOP with a valid application): reset.
//!
//! What runs as the application is always this build's firmware of the product whose
//! product code the installed image's header carries (an update may install another
//! product: the board's bootloader takes any product for its board): a flashed image is
//! data (its header and CRC are checked, its code is not run; the image co-simulator in
//! tests/cosim runs the real binaries). The bootloader polls without interrupts, so while it
//! runs the CPU is one that runs continuously ([`PdiCpu::runs_continuously`]): one round
//! of its main loop each time the board's clock moves.

use crate::models::esc::SyncEdge;
use crate::models::spi::EscSpi;
use crate::rig::board::{BoardIo, PdiCpu};
use crate::rig::firmware_cpu::{Device, FirmwareCpu};
use et1100::{Et1100, SpiPdi};
use firmware::platform::board::Board;
use firmware::platform::boot::header::{HeaderRepr, Target};
use firmware::platform::boot::install::{check_image, startup, Startup};
use firmware::platform::boot::layout::{APP_SLOT, BOOTSTRAP_MAILBOX};
use firmware::products::analog_io::layout::SYNC_MANAGERS;
use firmware::products::PRODUCTS;
use firmware::stacks::ethercat::boot_slave::{BootSlave, Bootstrap};
use lpc17xx_iap::model::FlashModel;
use lpc17xx_iap::{Iap, IapEntry};
use std::cell::RefCell;
use std::rc::Rc;

/// An update file (`.efw`): an image of `image_len` bytes (a pattern) after its header
/// block for `target` and `version`. The board runs this build's application whatever the
/// image holds.
pub fn update_file(image_len: usize, target: &Target, version: &str) -> Vec<u8> {
    let image: Vec<u8> = (0..image_len).map(|i| (i * 31 + 7) as u8).collect();
    let mut file = HeaderRepr::for_image(&image, target, version)
        .to_bytes()
        .to_vec();
    file.extend_from_slice(&image);
    file
}

/// The CPU clock the bootloader reports to the IAP ROM (kHz).
const CCLK_KHZ: u32 = 100_000;

/// The module's flash, shared between the programs and the test.
#[derive(Clone, Default)]
pub struct SharedFlash(pub Rc<RefCell<FlashModel>>);

impl SharedFlash {
    /// A flash with `efw` (an update file: header block, then the image) in the
    /// application slot, as `cargo xtask flash` writes it.
    pub fn with_application(efw: &[u8]) -> Self {
        let mut model = FlashModel::new().with_cclk_khz(CCLK_KHZ);
        model.load(APP_SLOT.start, efw);
        Self(Rc::new(RefCell::new(model)))
    }

    /// The header of the valid application in the slot for `board`, if there is one.
    pub fn application(&self, board: &Board) -> Option<HeaderRepr> {
        check_image(&Iap::new(self.clone(), CCLK_KHZ), APP_SLOT, board).ok()
    }

    /// What broke a rule of the IAP ROM so far (empty when all was well).
    pub fn violations(&self) -> Vec<String> {
        self.0.borrow().violations().to_vec()
    }
}

impl IapEntry for SharedFlash {
    fn call(&mut self, command: &[u32; 5], source: &[u8]) -> [u32; 5] {
        self.0.borrow_mut().call(command, source)
    }

    fn read_flash(&self, addr: u32, buf: &mut [u8]) {
        self.0.borrow().read_flash(addr, buf)
    }

    fn ram_address(&self, buf: &[u8]) -> u32 {
        self.0.borrow().ram_address(buf)
    }
}

/// What a test can see of the module from outside.
#[derive(Debug, Default)]
pub struct ModuleLog {
    /// The reset sequence's result at every reset, power-up first.
    pub startups: Vec<Startup>,
    /// Resets the application asked for (INIT -> BOOT).
    pub boot_requests: u32,
}

/// The bootloader's main loop on the board.
struct BootCpu {
    esc: Et1100<SpiPdi<EscSpi>>,
    slave: BootSlave<SharedFlash>,
    started: bool,
    reset: bool,
}

impl BootCpu {
    fn new(io: &BoardIo, board: Board, iap: Iap<SharedFlash>, application_valid: bool) -> Self {
        let bootstrap = Bootstrap {
            out: BOOTSTRAP_MAILBOX.0,
            inp: BOOTSTRAP_MAILBOX.1,
            out_control: SYNC_MANAGERS[0].control,
            in_control: SYNC_MANAGERS[1].control,
        };
        Self {
            esc: Et1100::new(SpiPdi::new(io.esc.clone())),
            slave: BootSlave::new(iap, board, bootstrap, application_valid),
            started: false,
            reset: false,
        }
    }

    /// One round of the loop (a failed access is retried in the next one).
    fn round(&mut self, io: &BoardIo) {
        let outcome = if self.started {
            let now_ms = (io.now_ns() / 1_000_000) as u32;
            self.slave.poll(&mut self.esc, now_ms)
        } else if io.esc.esc().borrow().pdi_operational() {
            let outcome = self.slave.start(&mut self.esc);
            self.started = outcome.is_ok();
            outcome
        } else {
            return;
        };
        self.reset |= outcome.is_ok_and(|o| o.reset);
    }
}

enum Program {
    Application(Box<FirmwareCpu>, Iap<SharedFlash>),
    Bootloader(Box<BootCpu>),
    /// Only while a reset moves the flash from one program to the next.
    Reset,
}

/// The module's CPU: the program that runs now and what survives a reset.
pub struct ModuleCpu {
    io: BoardIo,
    /// The board (its bootloader's): the first product's, whatever an update installs.
    board: Board,
    device: Device,
    adc_period_ns: u64,
    program: Program,
    /// The boot request word in RAM.
    boot_request: bool,
    log: Rc<RefCell<ModuleLog>>,
}

impl ModuleCpu {
    /// Power-up with `flash`; the application is `device` as [`FirmwareCpu::new`] runs it
    /// (`adc_period_ns`: its ADC timer).
    pub fn new(io: BoardIo, device: Device, adc_period_ns: u64, flash: SharedFlash) -> Self {
        let mut cpu = Self {
            io,
            board: *device.product.board,
            device,
            adc_period_ns,
            program: Program::Reset,
            boot_request: false,
            log: Rc::default(),
        };
        cpu.reset_with(Iap::new(flash, CCLK_KHZ));
        cpu
    }

    /// What a test sees of the module (shared: the board owns the CPU).
    pub fn log(&self) -> Rc<RefCell<ModuleLog>> {
        self.log.clone()
    }

    /// True while the bootloader runs.
    pub fn in_bootloader(&self) -> bool {
        matches!(self.program, Program::Bootloader(_))
    }

    /// The reset sequence with the flash `iap` reaches, then the program it chooses.
    fn reset_with(&mut self, mut iap: Iap<SharedFlash>) {
        let requested = core::mem::take(&mut self.boot_request);
        let board = self.board;
        let s = startup(&mut iap, &board, requested);
        self.log.borrow_mut().startups.push(s);
        // The application of the product the installed image is (the board keeps running
        // the last one when the harness does not run that product).
        if let Ok(header) = &s.application {
            let installed = PRODUCTS.iter().find(|p| {
                p.update
                    .is_some_and(|u| u.product_code == header.product_code)
            });
            if let Some(device) = installed.and_then(|p| self.device.running(p).ok()) {
                self.device = device;
            }
        }
        self.program = if s.stay.is_some() {
            let boot = BootCpu::new(&self.io, board, iap, s.application.is_ok());
            Program::Bootloader(Box::new(boot))
        } else {
            let app = FirmwareCpu::new(self.io.clone(), &self.device, self.adc_period_ns);
            Program::Application(Box::new(app), iap)
        };
    }

    /// Resets the CPU if the program asked for it.
    fn after_run(&mut self) {
        let reset = match &self.program {
            Program::Application(app, _) => app.bootloader_requested(),
            Program::Bootloader(boot) => boot.reset,
            Program::Reset => false,
        };
        if !reset {
            return;
        }
        let iap = match core::mem::replace(&mut self.program, Program::Reset) {
            Program::Application(_, iap) => {
                self.boot_request = true;
                self.log.borrow_mut().boot_requests += 1;
                iap
            }
            Program::Bootloader(boot) => boot.slave.into_iap(),
            Program::Reset => return,
        };
        self.reset_with(iap);
    }
}

impl PdiCpu for ModuleCpu {
    fn on_sync0(&mut self, io: &mut BoardIo, edge: &SyncEdge) {
        if let Program::Application(app, _) = &mut self.program {
            app.on_sync0(io, edge);
        }
    }

    fn on_irq(&mut self, io: &mut BoardIo) {
        if let Program::Application(app, _) = &mut self.program {
            app.on_irq(io);
        }
        self.after_run();
    }

    fn poll(&mut self, io: &mut BoardIo) {
        if let Program::Application(app, _) = &mut self.program {
            app.poll(io);
        }
        self.after_run();
    }

    fn next_timer_ns(&self) -> Option<u64> {
        match &self.program {
            Program::Application(app, _) => app.next_timer_ns(),
            _ => None,
        }
    }

    fn on_timer(&mut self, io: &mut BoardIo) {
        if let Program::Application(app, _) = &mut self.program {
            app.on_timer(io);
        }
    }

    fn runs_continuously(&self) -> bool {
        self.in_bootloader()
    }

    fn run_until(&mut self, io: &mut BoardIo, _t_ns: u64) {
        if let Program::Bootloader(boot) = &mut self.program {
            boot.round(io);
        }
        self.after_run();
    }
}
