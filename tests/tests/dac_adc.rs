//! AD5663 and AD7689 models at the SPI level.

use embedded_hal::digital::OutputPin;
use embedded_hal::spi::{Operation, SpiDevice};
use std::cell::RefCell;
use std::rc::Rc;
use virtual_board::models::adc::{Ad7689, AdcSpi, Signal, Source};
use virtual_board::models::dac::{Ad5663, DacSpi, LdacEdge, LdacPin, PowerMode};
use virtual_board::rig::clock::Clock;

fn dac() -> (Clock, Rc<RefCell<Ad5663>>, DacSpi, LdacPin) {
    let clock = Clock::new();
    let d = Rc::new(RefCell::new(Ad5663::new(clock.clone())));
    (clock, d.clone(), DacSpi::new(d.clone()), LdacPin::new(d))
}

fn word(spi: &mut DacSpi, w: u32) {
    spi.write(&[(w >> 16) as u8, (w >> 8) as u8, w as u8])
        .unwrap();
}

#[test]
fn dac_write_input_then_update() {
    let (clock, d, mut spi, _) = dac();
    clock.set_ns(1_000);
    word(&mut spi, 0x00_8000); // write input A, LDAC register 0: no output change
    assert_eq!(d.borrow().dac, [0, 0]);
    assert_eq!(d.borrow().input[0], 0x8000);
    clock.set_ns(2_000);
    word(&mut spi, 0x08_0000); // update DAC A
    let dd = d.borrow();
    assert_eq!(dd.dac[0], 0x8000);
    assert_eq!(dd.output_volts(0), Some(5.0));
    assert_eq!(dd.updates.len(), 1);
    assert_eq!((dd.updates[0].time_ns, dd.updates[0].channel), (2_000, 0));
}

#[test]
fn dac_write_b_and_update_all_latches_both_together() {
    let (clock, d, mut spi, _) = dac();
    word(&mut spi, 0x00_4000); // input A
    clock.set_ns(500);
    word(&mut spi, 0x11_C000); // write input B, update all (010, addr 001)
    let dd = d.borrow();
    assert_eq!(dd.dac, [0x4000, 0xC000]);
    assert!(dd.last_pair_simultaneous());
    assert_eq!(dd.output_volts(1), Some(7.5));
}

#[test]
fn dac_write_and_update_both_and_ldac_register() {
    let (_, d, mut spi, _) = dac();
    word(&mut spi, 0x1F_FFFF); // 011 write+update, addr 111 both
    assert_eq!(d.borrow().dac, [0xFFFF, 0xFFFF]);
    // Thesis setup 0x300003: both channels transparent.
    word(&mut spi, 0x30_0003);
    word(&mut spi, 0x01_1234); // write input B -> updates at once
    assert_eq!(d.borrow().dac[1], 0x1234);
}

#[test]
fn dac_ldac_pin_pulse_latches_non_transparent_channels() {
    let (clock, d, mut spi, mut ldac) = dac();
    word(&mut spi, 0x30_0002); // B transparent, A waits for LDAC
    word(&mut spi, 0x00_1111);
    assert_eq!(d.borrow().dac[0], 0);
    clock.set_ns(7_000);
    ldac.set_low().unwrap();
    ldac.set_high().unwrap();
    let dd = d.borrow();
    assert_eq!(dd.dac[0], 0x1111);
    assert_eq!(
        dd.updates.len(),
        1,
        "B (transparent) is not loaded by the pin"
    );
    assert_eq!(dd.updates[0].time_ns, 7_000);
}

#[test]
fn dac_power_down_reset_and_reserved() {
    let (_, d, mut spi, _) = dac();
    word(&mut spi, 0x1F_8000);
    word(&mut spi, 0x20_0032); // power-down 100k (DB5:4 = 11? no: 0x30 = tri, 0x20 = 100k), B only
    assert_eq!(d.borrow().power, [PowerMode::Normal, PowerMode::ThreeState]);
    assert_eq!(d.borrow().output_volts(1), None);
    word(&mut spi, 0x20_0021);
    assert_eq!(d.borrow().power[0], PowerMode::PullDown100k);
    word(&mut spi, 0x38_0001); // 111: reserved on the AD5663
    assert_eq!(d.borrow().reserved_commands, 1);
    word(&mut spi, 0x30_0003);
    word(&mut spi, 0x28_0000); // reset DAC/input registers only
    assert_eq!(d.borrow().dac, [0, 0]);
    assert_eq!(d.borrow().ldac_reg, 3);
    word(&mut spi, 0x28_0001); // reset all
    assert_eq!(d.borrow().ldac_reg, 0);
    assert_eq!(d.borrow().power, [PowerMode::Normal; 2]);
}

#[test]
fn dac_short_frame_is_aborted() {
    let (_, d, mut spi, _) = dac();
    spi.write(&[0x18, 0x80]).unwrap();
    assert_eq!(d.borrow().aborted_frames, 1);
    assert_eq!(d.borrow().frames, 0);
    // A frame split over several operations is one frame.
    spi.transaction(&mut [Operation::Write(&[0x18]), Operation::Write(&[0x80, 0x00])])
        .unwrap();
    assert_eq!(d.borrow().dac[0], 0x8000);
}

fn adc() -> (Clock, Rc<RefCell<Ad7689>>, AdcSpi) {
    let clock = Clock::new();
    let a = Rc::new(RefCell::new(Ad7689::new(clock.clone())));
    (clock, a.clone(), AdcSpi::new(a))
}

/// One 16-bit frame: CFG out, data in.
fn frame16(clock: &Clock, spi: &mut AdcSpi, cfg: u16) -> u16 {
    let w = cfg << 2;
    let mut buf = [(w >> 8) as u8, w as u8];
    spi.transfer_in_place(&mut buf).unwrap();
    clock.advance_ns(4_000);
    u16::from_be_bytes(buf)
}

/// Unipolar vs GND, external reference (110), scan IN0..IN7, no readback.
const CFG_SCAN_EXT: u16 = 0x3FF7;

#[test]
fn adc_pipeline_and_dummy_conversions() {
    let (clock, a, mut spi) = adc();
    for ch in 0..8 {
        a.borrow_mut().inputs[ch] = Signal::Constant(ch as f64 + 1.0);
    }
    // Frames 0 and 1: dummy conversions after power-up.
    assert_eq!(frame16(&clock, &mut spi, CFG_SCAN_EXT), 0);
    assert_eq!(frame16(&clock, &mut spi, 0), 0);
    let conv = a.borrow().conversions.clone();
    assert_eq!(conv[0].source, Source::Dummy);
    assert_eq!(conv[1].source, Source::Dummy);
    assert_eq!(conv[2].source, Source::Channel(0));
    // Frame 2 carries the first conversion under the CFG of frame 0: IN0.
    let codes: Vec<u16> = (0..9).map(|_| frame16(&clock, &mut spi, 0)).collect();
    let expect = |v: f64| (v / 4.0 / 2.5 * 65536.0) as u16;
    for (k, code) in codes.iter().enumerate() {
        let ch = k % 8;
        assert_eq!(*code, expect(ch as f64 + 1.0), "frame {} = IN{}", k + 2, ch);
    }
}

#[test]
fn adc_cfg_takes_effect_two_frames_later() {
    let (clock, a, mut spi) = adc();
    a.borrow_mut().inputs[3] = Signal::Constant(10.0);
    a.borrow_mut().inputs[5] = Signal::Constant(5.0);
    // Single channel IN3, no sequencer: INCC 111, IN3, full BW, ext ref 110, SEQ 00, RB 1.
    let cfg_in3 = 0x2000 | 0b111 << 10 | 3 << 7 | 1 << 6 | 0b110 << 3 | 1;
    let cfg_in5 = 0x2000 | 0b111 << 10 | 5 << 7 | 1 << 6 | 0b110 << 3 | 1;
    frame16(&clock, &mut spi, cfg_in3);
    frame16(&clock, &mut spi, 0);
    assert_eq!(
        frame16(&clock, &mut spi, cfg_in5),
        0xFFFF,
        "IN3 at full scale"
    );
    assert_eq!(
        frame16(&clock, &mut spi, 0),
        0xFFFF,
        "still IN3: CFG of frame N+0"
    );
    assert_eq!(
        frame16(&clock, &mut spi, 0),
        0x8000,
        "frame N+2 has IN5 (5 V)"
    );
}

#[test]
fn adc_readback_gives_32_bit_frames_and_temperature_in_sequence() {
    let (clock, a, mut spi) = adc();
    // Scan IN0..IN1 then temperature (SEQ = 10), readback on (RB = 0).
    let cfg = 0x2000 | 0b111 << 10 | 1 << 7 | 1 << 6 | 0b110 << 3 | 0b10 << 1;
    let mut buf = [0u8; 4];
    let w = (cfg << 2) as u16;
    buf[..2].copy_from_slice(&w.to_be_bytes());
    spi.transfer_in_place(&mut buf).unwrap();
    for _ in 0..2 {
        let mut z = [0u8; 4];
        spi.transfer_in_place(&mut z).unwrap();
    }
    let mut sources = Vec::new();
    for _ in 0..6 {
        let mut z = [0u8; 4];
        spi.transfer_in_place(&mut z).unwrap();
        assert_eq!(
            u16::from_be_bytes([z[2], z[3]]),
            (cfg << 2) as u16,
            "CFG read back"
        );
        clock.advance_ns(4_000);
    }
    for c in a.borrow().conversions.iter().skip(2) {
        sources.push(c.source);
    }
    assert_eq!(
        &sources[..6],
        &[
            Source::Channel(0),
            Source::Channel(1),
            Source::Temperature,
            Source::Channel(0),
            Source::Channel(1),
            Source::Temperature
        ]
    );
    let t = a.borrow().conversions[4];
    assert_eq!(t.code, (0.283 / 2.5 * 65536.0) as u16, "283 mV at 25 C");
}

#[test]
fn adc_samples_signals_at_the_conversion_time() {
    let (clock, a, mut spi) = adc();
    a.borrow_mut().inputs[0] = Signal::Ramp {
        from: 0.0,
        to: 10.0,
        period_ns: 1_000_000,
    };
    let cfg_in0 = 0x2000 | 0b111 << 10 | 1 << 6 | 0b110 << 3 | 1;
    frame16(&clock, &mut spi, cfg_in0);
    frame16(&clock, &mut spi, 0);
    clock.set_ns(500_000);
    frame16(&clock, &mut spi, 0); // conversion at t = 500 us starts here
    let c = *a.borrow().conversions.last().unwrap();
    assert_eq!(c.time_ns, 500_000);
    assert_eq!(c.code, 0x8000, "ramp at half: 5 V -> 1.25 V at the pin");
    assert_eq!(frame16(&clock, &mut spi, 0), 0x8000);
    let s = Signal::Sine {
        amplitude: 2.0,
        offset: 5.0,
        freq_hz: 1000.0,
        phase: 0.0,
    };
    assert!((s.eval(250_000) - 7.0).abs() < 1e-9);
    assert_eq!(a.borrow().cycle_violations, 0, "4 us between conversions");
    spi.transfer_in_place(&mut [0, 0]).unwrap();
    spi.transfer_in_place(&mut [0, 0]).unwrap();
    assert_eq!(a.borrow().cycle_violations, 1, "CNV edges closer than tCYC");
}

// ---------------------------------------------------------------- pin level

/// The two 12-bit items of one 24-bit DAC word (an SSP with 12-bit frames).
fn items12(w: u32) -> [u32; 2] {
    [(w >> 12) & 0xFFF, w & 0xFFF]
}

/// A frame in two 12-bit pieces with SCLK idle between them executes when its 24th bit is
/// in, at that time; LDAC then loads both channels at its falling edge, and every LDAC edge
/// is kept with its time.
#[test]
fn dac_frames_in_pieces_and_ldac_edges_with_their_times() {
    let (clock, d, _, mut ldac) = dac();
    for (t, w) in [(1_000, 0x00_1234u32), (3_000, 0x01_ABCD)] {
        clock.set_ns(t);
        d.borrow_mut().sync_falling();
        let [a, b] = items12(w);
        d.borrow_mut().clock_bits(a, 12);
        assert_eq!(d.borrow().frames, u64::from(t == 3_000), "12 bits: not yet");
        clock.set_ns(t + 700);
        d.borrow_mut().clock_bits(b, 12);
        d.borrow_mut().sync_rising();
    }
    assert_eq!(d.borrow().input, [0x1234, 0xABCD]);
    assert_eq!(
        d.borrow().dac,
        [0, 0],
        "LDAC register 0, pin high: no change"
    );
    clock.set_ns(20_000);
    ldac.set_low().unwrap();
    clock.set_ns(20_200);
    ldac.set_high().unwrap();
    ldac.set_high().unwrap(); // no edge
    let dd = d.borrow();
    assert_eq!(dd.dac, [0x1234, 0xABCD]);
    assert!(dd.last_pair_simultaneous());
    assert_eq!(dd.updates.last().unwrap().time_ns, 20_000);
    assert_eq!(
        dd.ldac_edges,
        [
            LdacEdge {
                time_ns: 20_000,
                falling: true
            },
            LdacEdge {
                time_ns: 20_200,
                falling: false
            }
        ]
    );
    assert_eq!(dd.ldac_falls_since(20_001).count(), 0);
    assert_eq!(dd.ldac_falls_since(0).count(), 1);
}

#[test]
fn dac_pin_level_aborts_long_frames_and_deselected_bits() {
    let (_, d, _, _) = dac();
    let mut dd = d.borrow_mut();
    dd.clock_bits(0xFFF, 12);
    assert_eq!(dd.bits_while_deselected, 12, "SYNC high: ignored");
    dd.sync_falling();
    dd.clock_bits(0x180, 12);
    dd.sync_rising();
    assert_eq!(
        (dd.aborted_frames, dd.frames),
        (1, 0),
        "SYNC rose after 12 bits"
    );
    // 32 bits in one piece: the first 24 are the word (write and update A), the rest ignored.
    dd.sync_falling();
    dd.clock_bits(0x18_8000 << 8 | 0xAA, 32);
    dd.sync_rising();
    assert_eq!((dd.frames, dd.long_frames), (1, 1));
    assert_eq!(dd.dac[0], 0x8000);
}

#[test]
fn ldac_grid_error_is_the_distance_to_the_nearest_grid_point() {
    let e = |t| LdacEdge {
        time_ns: t,
        falling: true,
    };
    assert_eq!(e(1_000_050).grid_error_ns(0, 20_000), 50);
    assert_eq!(e(999_970).grid_error_ns(0, 20_000), -30);
    assert_eq!(e(1_010_000).grid_error_ns(0, 20_000), 10_000);
    assert_eq!(e(1_010_001).grid_error_ns(0, 20_000), -9_999);
    assert_eq!(
        e(500).grid_error_ns(1_000, 20_000),
        -500,
        "before the origin"
    );
    assert_eq!(e(1_250).grid_error_ns(1_000, 0), 250);
}

/// The CNV waveform the firmware makes (rise, high 2.3 us, fall, read, next rise 4 us after
/// the last): nothing to count; each breach counted by its kind.
#[test]
fn adc_checks_the_conversion_timing_at_its_pins() {
    let (clock, a, _) = adc();
    let cycle = |t0: u64, high: u64, read_at: Option<u64>| {
        clock.set_ns(t0);
        a.borrow_mut().cnv_rising();
        clock.set_ns(t0 + high);
        a.borrow_mut().cnv_falling();
        if let Some(r) = read_at {
            clock.set_ns(t0 + r);
            a.borrow_mut().read(&[0, 0]);
        }
    };
    // The power-up conversion runs: CNV starts high.
    a.borrow_mut().cnv_falling();
    for k in 0..10 {
        cycle(10_000 + k * 4_000, 2_300, Some(2_320));
    }
    assert_eq!(a.borrow().timing_violations(), 0);
    assert_eq!(a.borrow().conversions.len(), 11);
    // CNV falls before tCONV(max): the result is not ready.
    cycle(60_000, 2_000, Some(2_100));
    assert_eq!(a.borrow().violations.conversion_cut, 1);
    // A 5 ns pulse: too short, and the conversion is cut.
    cycle(70_000, 5, None);
    assert_eq!(a.borrow().violations.short_pulse, 1);
    assert_eq!(a.borrow().violations.conversion_cut, 2);
    // The next rise 3.99 us after the last: tCYC.
    cycle(73_990, 2_300, Some(2_400));
    assert_eq!(a.borrow().cycle_violations, 1);
    // A read while CNV is high.
    clock.set_ns(80_000);
    a.borrow_mut().cnv_rising();
    a.borrow_mut().read(&[0, 0]);
    assert_eq!(a.borrow().violations.read_while_converting, 1);
    assert_eq!(a.borrow().timing_violations(), 5);
    // Repeated edges of one level are one edge.
    a.borrow_mut().cnv_rising();
    assert_eq!(a.borrow().conversions.len(), 15);
}

/// A read at the pin level carries a CFG like a frame: the scan it sets up follows the same
/// pipeline (data of the first channel two conversions later).
#[test]
fn adc_pin_level_reads_follow_the_cfg_pipeline() {
    let (clock, a, _) = adc();
    for ch in 0..8 {
        a.borrow_mut().inputs[ch] = Signal::Constant(ch as f64 + 1.0);
    }
    a.borrow_mut().cnv_falling();
    let mut codes = Vec::new();
    for k in 0..12u64 {
        let t0 = 4_000 * (k + 1);
        clock.set_ns(t0 - 1_500);
        let cfg = if k == 0 { CFG_SCAN_EXT << 2 } else { 0 };
        let miso = a.borrow_mut().read(&[(cfg >> 8) as u8, cfg as u8]);
        codes.push(u16::from_be_bytes([miso[0], miso[1]]));
        clock.set_ns(t0);
        a.borrow_mut().cnv_rising();
        clock.set_ns(t0 + 2_300);
        a.borrow_mut().cnv_falling();
    }
    let expect = |v: f64| (v / 4.0 / 2.5 * 65536.0) as u16;
    assert_eq!(&codes[..2], [0, 0], "power-up dummies");
    for (k, code) in codes[2..].iter().enumerate() {
        assert_eq!(*code, expect((k % 8) as f64 + 1.0), "read {}", k + 2);
    }
    assert_eq!(a.borrow().timing_violations(), 0);
}
