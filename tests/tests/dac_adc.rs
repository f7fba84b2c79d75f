//! AD5663 and AD7689 models at the SPI level.

use embedded_hal::digital::OutputPin;
use embedded_hal::spi::{Operation, SpiDevice};
use std::cell::RefCell;
use std::rc::Rc;
use virtual_board::models::adc::{Ad7689, AdcSpi, Signal, Source};
use virtual_board::models::dac::{Ad5663, DacSpi, LdacPin, PowerMode};
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
