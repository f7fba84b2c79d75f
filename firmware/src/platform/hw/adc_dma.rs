//! AD7689 sampling by Timer2 + GPDMA (UM10360 chapters 21, 31, 18; hardware-facts 10.B):
//! the register writes of the plan in `firmware::platform::chip::adc_dma`, which holds every list,
//! word and timing computation (host-tested); the ring is read by `firmware::io::analog::adc_dma`.
//!
//! * Timer2: MR3 resets TC every 4 us; MAT2.0 (P0.6 = CNV) toggles on MR0; MR0 and MR1 raise
//!   GPDMA requests 12 and 13 (DMAREQSEL bits 4 and 5). No timer interrupt.
//! * GPDMA channel 0 (highest priority): SSP1 RX -> 3 start-up dummies -> the ring in AHB
//!   SRAM, two halves, terminal-count interrupt per half (the only interrupt: ~every 2 ms).
//! * Channel 1: on T2MR0, MR0 <- the next CNV edge (fall after the rise, rise after the fall).
//! * Channel 2: on T2MR1, SSP1 DR <- CFG, CFG, then the NOP word: one 16-bit frame per period.
//!
//! Everything the DMA touches (ring, lists, source words) is in AHB SRAM (`.ahbsram`).

use super::ssp::Ssp;
use core::mem::MaybeUninit;
use core::sync::atomic::{AtomicBool, AtomicU16, AtomicU32, Ordering};
use firmware::io::analog::adc_dma::{words_written, HalfCounter, PositionError, RING_WORDS};
use firmware::platform::chip::adc_dma::{
    cnv_chain, rx_chain, tx_chain, word0_after_start_ns, CnvAddresses, RxAddresses, TxAddresses,
    CNV_RISE, FRAME_START, MR0_SEQUENCE, PERIOD_TICKS, TICK_NS, TX_WORDS,
};
use firmware::platform::chip::gpdma::{config_m2p, config_p2m, request, Chain, Lli};
use lpc17xx_pac as pac;

/// Confirmed (UM10360 Rev. 3 p. 500, chapter 21 remark): timer DMA requests are generated
/// whenever TC equals the match register, so they run as soon as the timer does; hence the
/// channels are enabled while Timer2 is held in reset (TC = 0 matches neither MR0 nor MR1)
/// and the timer is started last.
///
/// UNCONFIRMED (no board here; hardware-facts 10.B item 8): behaviour this module relies on
/// that no source at hand states.
/// * The match's DMA request is independent of the MCR interrupt bits and of the EMR pin
///   action, is held until the GPDMA services it (TC equals MR for one PCLK only), and a
///   stale one from before the setup is cleared by writing its IR flag.
/// * The GPDMA reaches the AHB SRAM and the APB peripherals but not the local SRAM at
///   0x1000_0000 (so nothing the DMA reads or writes lives there).
/// * DMACCxDestAddr, read while the channel runs, is the address of the next write.
/// * Half-word GPDMA writes to SSP1 DR (a 32-bit APB register) send one 16-bit frame.
mod unconfirmed {
    /// IR bits of MR0 and MR1 (write 1 to clear; also clears their pending DMA requests).
    pub const TIMER_IR_MR0_MR1: u32 = 0b11;
}

/// Channels (0 has the highest priority: the RX FIFO must not overflow).
const CH_RX: usize = 0;
const CH_CNV: usize = 1;
const CH_TX: usize = 2;

/// PCONP bit of the GPDMA (hardware-facts 7; `lpc1769` PAC PCGPDMA).
const PCONP_GPDMA: u32 = 1 << 29;
/// DMACConfig E (controller enable, little-endian masters).
const DMAC_ENABLE: u32 = 1;
/// Timer register values (UM10360 21.6): TCR, MCR MR3R (b10), EMR EMC0 bits 5:4 = 11 toggle.
const TCR_ENABLE: u32 = 1;
const TCR_RESET: u32 = 2;
const MCR_MR3R: u32 = 1 << 10;
const EMR_EMC0_TOGGLE: u32 = 0b11 << 4;

/// What the GPDMA reads and writes, in AHB SRAM.
#[repr(C)]
struct DmaMemory {
    ring: [AtomicU16; RING_WORDS],
    skip: AtomicU16,
    tx_words: [u16; 2],
    cnv_table: [u32; 2],
    rx_items: [Lli; 2],
    tx_items: [Lli; 1],
    cnv_items: [Lli; 1],
}

#[link_section = ".ahbsram.adc_dma"]
static mut DMA_MEMORY: MaybeUninit<DmaMemory> = MaybeUninit::uninit();
static DMA_MEMORY_TAKEN: AtomicBool = AtomicBool::new(false);

/// Halves completed (the GPDMA interrupt's count) and DMA errors.
static HALVES: HalfCounter = HalfCounter::new();
static DMA_ERRORS: AtomicU32 = AtomicU32::new(0);

fn addr<T>(r: &T) -> u32 {
    r as *const T as u32
}

/// Timer2 + SSP1 + GPDMA, configured and stopped.
pub struct AdcDma {
    t: pac::TIMER2,
    _ssp: Ssp<pac::SSP1>,
    dma: pac::GPDMA,
    memory: &'static DmaMemory,
}

/// The PDI task's view of the running DMA: the ring and its write position.
#[derive(Clone, Copy)]
pub struct DmaRing {
    /// The ring the RX channel fills.
    pub ring: &'static [AtomicU16; RING_WORDS],
    ring_addr: u32,
    skip_addr: u32,
}

impl DmaRing {
    /// Words written into the ring so far ([`words_written`] from the half count and the RX
    /// channel's destination address, read consistently).
    pub fn words_written(&self) -> Result<u32, PositionError> {
        // SAFETY: a read of the channel's destination address has no side effect.
        let dma = unsafe { &*pac::GPDMA::ptr() };
        let mut halves = HALVES.get();
        let mut dst = dma.destaddr0.read().bits();
        for _ in 0..3 {
            let again = HALVES.get();
            if again == halves {
                break;
            }
            // The interrupt ran in between: read the address again under the new count.
            halves = again;
            dst = dma.destaddr0.read().bits();
        }
        words_written(halves, dst, self.ring_addr, self.skip_addr)
    }
}

impl AdcDma {
    /// Writes the lists into AHB SRAM and configures Timer2, SSP1 and the three channels
    /// (nothing runs until [`start`](Self::start)). `None` if called twice.
    pub fn new(t: pac::TIMER2, mut ssp: Ssp<pac::SSP1>, dma: pac::GPDMA) -> Option<Self> {
        if DMA_MEMORY_TAKEN.swap(true, Ordering::AcqRel) {
            return None;
        }
        // SAFETY: the flag hands the static out once; every field is written before use.
        let slot = unsafe { &mut *core::ptr::addr_of_mut!(DMA_MEMORY) };
        let base = slot.as_mut_ptr();
        // Addresses first (the lists point at each other), then the contents.
        // SAFETY: field addresses of the static, no reference to uninitialised data.
        let (ring_a, skip_a, tx_a, table_a, rx_i, tx_i, cnv_i) = unsafe {
            (
                core::ptr::addr_of!((*base).ring) as u32,
                core::ptr::addr_of!((*base).skip) as u32,
                core::ptr::addr_of!((*base).tx_words) as u32,
                core::ptr::addr_of!((*base).cnv_table) as u32,
                core::ptr::addr_of!((*base).rx_items) as u32,
                core::ptr::addr_of!((*base).tx_items) as u32,
                core::ptr::addr_of!((*base).cnv_items) as u32,
            )
        };
        let lli = core::mem::size_of::<Lli>() as u32;
        let ssp_dr = ssp.dr_address();
        let rx = rx_chain(RxAddresses {
            ssp_dr,
            skip: skip_a,
            ring: ring_a,
            items: [rx_i, rx_i + lli],
        });
        let tx = tx_chain(TxAddresses {
            ssp_dr,
            cfg: tx_a,
            nop: tx_a + 2,
            item: tx_i,
        });
        let cnv = cnv_chain(CnvAddresses {
            mr0: addr(&t.mr[0]),
            table: table_a,
            item: cnv_i,
        });
        // Field by field, in place (the ring alone is 2 KB: not through the stack).
        // SAFETY: `base` points at the static; each field is written once, then the whole is
        // initialised and only shared from here on.
        let memory: &'static DmaMemory = unsafe {
            let ring = core::ptr::addr_of_mut!((*base).ring) as *mut AtomicU16;
            for i in 0..RING_WORDS {
                ring.add(i).write(AtomicU16::new(0));
            }
            core::ptr::addr_of_mut!((*base).skip).write(AtomicU16::new(0));
            core::ptr::addr_of_mut!((*base).tx_words).write(TX_WORDS);
            core::ptr::addr_of_mut!((*base).cnv_table).write(MR0_SEQUENCE);
            core::ptr::addr_of_mut!((*base).rx_items).write(rx.items);
            core::ptr::addr_of_mut!((*base).tx_items).write(tx.items);
            core::ptr::addr_of_mut!((*base).cnv_items).write(cnv.items);
            &*(base as *const DmaMemory)
        };

        // SAFETY (all register writes below): documented values (UM10360 21.6, 31.5; SYSCON
        // PCONP and DMAREQSEL at 0x400F_C0C4 / 0x400F_C1C4, `lpc1769` PAC).
        let syscon = unsafe { &*pac::SYSCON::ptr() };
        syscon
            .pconp
            .modify(|r, w| unsafe { w.bits(r.bits() | PCONP_GPDMA) });
        let sel = request::dmareqsel_bit(request::T2_MR0) | request::dmareqsel_bit(request::T2_MR1);
        syscon
            .dmacreqsel
            .modify(|r, w| unsafe { w.bits(r.bits() | sel) });

        t.tcr.write(|w| unsafe { w.bits(TCR_RESET) });
        t.pr.write(|w| unsafe { w.bits(0) });
        t.ctcr.write(|w| unsafe { w.bits(0) });
        t.mr[0].write(|w| unsafe { w.bits(CNV_RISE) });
        t.mr[1].write(|w| unsafe { w.bits(FRAME_START) });
        t.mr[3].write(|w| unsafe { w.bits(PERIOD_TICKS - 1) });
        t.mcr.write(|w| unsafe { w.bits(MCR_MR3R) });
        // EM0 = 0: CNV low until the first MR0 match toggles it.
        t.emr.write(|w| unsafe { w.bits(EMR_EMC0_TOGGLE) });
        t.ir.write(|w| unsafe { w.bits(0x3F | unconfirmed::TIMER_IR_MR0_MR1) });

        ssp.enable_rx_dma();

        dma.config.write(|w| unsafe { w.bits(DMAC_ENABLE) });
        let mask = (1 << CH_RX) | (1 << CH_CNV) | (1 << CH_TX);
        dma.inttcclear.write(|w| unsafe { w.bits(mask) });
        dma.interrclr.write(|w| unsafe { w.bits(mask) });
        let mut s = Self {
            t,
            _ssp: ssp,
            dma,
            memory,
        };
        s.load(CH_RX, &rx, config_p2m(request::SSP1_RX));
        s.load(CH_CNV, &cnv, config_m2p(request::T2_MR0));
        s.load(CH_TX, &tx, config_m2p(request::T2_MR1));
        Some(s)
    }

    /// Loads a channel's registers from the first item and enables it (it then waits for
    /// its request line).
    fn load<const K: usize>(&mut self, ch: usize, chain: &Chain<K>, config: u32) {
        let d = &self.dma;
        let (src, dst, lli, control, cfg) = match ch {
            CH_RX => (&d.srcaddr0, &d.destaddr0, &d.lli0, &d.control0, &d.config0),
            CH_CNV => (&d.srcaddr1, &d.destaddr1, &d.lli1, &d.control1, &d.config1),
            _ => (&d.srcaddr2, &d.destaddr2, &d.lli2, &d.control2, &d.config2),
        };
        let f = chain.first;
        // The items in memory are complete before the channel can fetch them.
        cortex_m::asm::dsb();
        // SAFETY: channel registers (UM10360 31.5.14-31.5.18), values from the tested plan.
        unsafe {
            cfg.write(|w| w.bits(0));
            src.write(|w| w.bits(f.src));
            dst.write(|w| w.bits(f.dst));
            lli.write(|w| w.bits(f.next));
            control.write(|w| w.bits(f.control));
            cfg.write(|w| w.bits(config));
        }
    }

    /// The ring and its position for the PDI task.
    pub fn ring(&self) -> DmaRing {
        DmaRing {
            ring: &self.memory.ring,
            ring_addr: addr(&self.memory.ring),
            skip_addr: addr(&self.memory.skip),
        }
    }

    /// Starts the conversions; the TIMER2 interrupt stays masked (no timer interrupt is
    /// used on this path). Returns the time base's time ([`crate::hw::timers::now_ns`]) of
    /// ring word 0's conversion: Timer2's start, from its counter read right after the
    /// time base, plus the start-up frames ([`word0_after_start_ns`]).
    pub fn start(&mut self) -> u64 {
        cortex_m::peripheral::NVIC::mask(pac::Interrupt::TIMER2);
        // SAFETY: TCR enable.
        self.t.tcr.write(|w| unsafe { w.bits(TCR_ENABLE) });
        if !firmware::io::analog::oversampling::BUILT {
            return 0;
        }
        let now = crate::hw::timers::now_ns();
        let tc = u64::from(self.t.tc.read().bits());
        now.saturating_sub(tc * u64::from(TICK_NS)) + word0_after_start_ns()
    }

    /// Clears Timer2's flags other than MR0/MR1 (clearing those might drop a pending DMA
    /// request: UNCONFIRMED) and masks TIMER2 again; only called if TIMER2 fires, which this
    /// path does not expect.
    pub fn silence_timer_interrupt(&mut self) {
        // SAFETY: IR is write-1-to-clear; bits 2..5 = MR2, MR3, CR0, CR1.
        self.t.ir.write(|w| unsafe { w.bits(0x3C) });
        cortex_m::peripheral::NVIC::mask(pac::Interrupt::TIMER2);
    }

    /// GPDMA errors seen by the interrupt (a channel stops on an error).
    pub fn errors() -> u32 {
        DMA_ERRORS.load(Ordering::Relaxed)
    }
}

/// The GPDMA interrupt: counts a completed half ring; counts (and clears) errors.
pub fn on_dma_interrupt() {
    // SAFETY: status reads and write-1-to-clear writes of the GPDMA (UM10360 31.5.2-31.5.5).
    let dma = unsafe { &*pac::GPDMA::ptr() };
    let tc = dma.inttcstat.read().bits();
    if tc != 0 {
        dma.inttcclear.write(|w| unsafe { w.bits(tc) });
        if tc & (1 << CH_RX) != 0 {
            HALVES.on_terminal_count();
        }
    }
    let err = dma.interrstat.read().bits();
    if err != 0 {
        dma.interrclr.write(|w| unsafe { w.bits(err) });
        let n = DMA_ERRORS.load(Ordering::Relaxed);
        DMA_ERRORS.store(n.wrapping_add(1), Ordering::Relaxed);
    }
}
