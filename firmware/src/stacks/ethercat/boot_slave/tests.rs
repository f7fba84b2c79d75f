use super::*;
use crate::fake_esc::FakeEsc;
use crate::platform::board::{Board, Options, THESIS};
use crate::platform::boot::header::HeaderRepr;
use crate::platform::boot::header::Target;
use crate::platform::boot::install::{check_image, startup};
use crate::platform::boot::layout::{APP_SLOT, STAGING};

/// The board of the tests' bootloader and what its files are built for.
const BOARD: Board = THESIS;
const UPDATE_TARGET: Target = Target::new(BOARD.vendor_id, 0x1754, &BOARD, Options::NONE);
use crate::products::analog_io::layout::{BOOTSTRAP_MAILBOX, SYNC_MANAGERS};
use coe_core::wire::{Foe, FoeErrorCode, FoeRepr};
use lpc17xx_iap::model::FlashModel;
use std::vec::Vec;

const CCLK_KHZ: u32 = 100_000;
const MBX: usize = BOOTSTRAP_MAILBOX_SIZE;

fn bootstrap() -> Bootstrap {
    Bootstrap {
        out: BOOTSTRAP_MAILBOX.0,
        inp: BOOTSTRAP_MAILBOX.1,
        out_control: SYNC_MANAGERS[0].control,
        in_control: SYNC_MANAGERS[1].control,
    }
}

struct Rig {
    esc: FakeEsc,
    slave: BootSlave<FlashModel>,
    now_ms: u32,
    counter: u8,
}

impl Rig {
    fn new(application_valid: bool) -> Self {
        let iap = Iap::new(FlashModel::new().with_cclk_khz(CCLK_KHZ), CCLK_KHZ);
        let mut esc = FakeEsc::new();
        let mut slave = BootSlave::new(iap, BOARD, bootstrap(), application_valid);
        assert!(!slave.start(&mut esc.driver()).unwrap().reset);
        Self {
            esc,
            slave,
            now_ms: 0,
            counter: 0,
        }
    }

    /// Polls a few rounds (the main loop).
    fn run(&mut self) -> BootOutcome {
        let mut out = BootOutcome::default();
        for _ in 0..4 {
            self.now_ms += 1;
            let o = self
                .slave
                .poll(&mut self.esc.driver(), self.now_ms)
                .unwrap();
            out.reset |= o.reset;
        }
        out
    }

    fn request(&mut self, state: u16) -> ((u16, u16), BootOutcome) {
        self.esc.master_al_control(state);
        let out = self.run();
        (self.esc.al_status(), out)
    }

    fn boot_sms(&mut self) {
        let (out, inp) = BOOTSTRAP_MAILBOX;
        self.esc.master_sm(0, out.start, out.len, 0x26, true);
        self.esc.master_sm(1, inp.start, inp.len, 0x22, true);
    }

    /// One FoE packet through the bootstrap mailbox; the answer.
    fn foe(&mut self, packet: FoeRepr<'_>) -> Vec<u8> {
        self.counter = self.counter % 7 + 1;
        let mut f = std::vec![0u8; 6 + packet.buffer_len()];
        f[0..2].copy_from_slice(&(packet.buffer_len() as u16).to_le_bytes());
        f[5] = 0x04 | self.counter << 4;
        packet.emit(&mut Foe::new_unchecked(&mut f[6..])).unwrap();
        assert!(self.esc.master_write_mailbox(&f));
        self.run();
        let reply = self.esc.master_read_mailbox().expect("an answer");
        let n = usize::from(u16::from_le_bytes([reply[0], reply[1]]));
        assert_eq!(reply[5] & 0x0F, 0x04, "FoE");
        reply[6..6 + n].to_vec()
    }

    fn write_file(&mut self, name: &[u8], content: &[u8]) -> Result<(), (FoeErrorCode, Vec<u8>)> {
        let answer = |bytes: &[u8]| match FoeRepr::parse(&Foe::new_unchecked(bytes)).unwrap() {
            FoeRepr::Ack { packet_number } => Ok(packet_number),
            FoeRepr::Error { code, text } => Err((code, text.to_vec())),
            other => panic!("{other:?}"),
        };
        let a = self.foe(FoeRepr::WriteRequest {
            password: 0,
            file_name: name,
        });
        assert_eq!(answer(&a)?, 0);
        let room = MBX - 12;
        let mut chunks: Vec<&[u8]> = content.chunks(room).collect();
        if content.len() % room == 0 {
            chunks.push(&[]);
        }
        for (i, data) in chunks.into_iter().enumerate() {
            let n = i as u32 + 1;
            let a = self.foe(FoeRepr::Data {
                packet_number: n,
                data,
            });
            assert_eq!(answer(&a)?, n);
        }
        Ok(())
    }
}

fn update_file(version: &str) -> (Vec<u8>, HeaderRepr) {
    let image: Vec<u8> = (0..9_000u32).map(|i| (i * 13 + 5) as u8).collect();
    let header = HeaderRepr::for_image(&image, &UPDATE_TARGET, version);
    let mut file = header.to_bytes().to_vec();
    file.extend_from_slice(&image);
    (file, header)
}

#[test]
fn boot_needs_the_bootstrap_mailbox() {
    let mut r = Rig::new(true);
    assert_eq!(r.esc.al_status(), (0x01, 0));
    // The standard mailbox configured instead: 0x0015.
    r.esc.master_sm(0, 0x1000, 128, 0x26, true);
    r.esc.master_sm(1, 0x1080, 128, 0x22, true);
    assert_eq!(r.request(0x03).0, (0x11, 0x0015));
    r.boot_sms();
    let (status, out) = r.request(0x13);
    assert_eq!(status, (0x03, 0));
    assert!(!out.reset);
    assert_eq!(r.slave.state(), AlState::Bootstrap);
    // Forbidden from BOOT: PREOP, SAFEOP, OP (0x0011).
    for state in [0x02, 0x04, 0x08] {
        assert_eq!(r.request(state).0, (0x13, 0x0011), "BOOT -> {state:#x}");
        r.request(0x13);
    }
}

#[test]
fn an_update_over_foe_then_boot_to_init_resets() {
    let mut r = Rig::new(true);
    r.boot_sms();
    r.request(0x03);
    let (file, header) = update_file("2.0.0");
    r.write_file(b"analog-io.efw", &file).unwrap();
    assert_eq!(r.slave.files().staged(), Some(&header));
    let (status, out) = r.request(0x01);
    assert_eq!(status, (0x01, 0));
    assert!(out.reset, "BOOT -> INIT resets into the reset sequence");
    // The reset sequence installs it.
    let iap = r.slave.files_mut().iap_mut();
    assert_eq!(check_image(iap, STAGING, &BOARD), Ok(header));
    let s = startup(iap, &BOARD, false);
    assert!(s.installed);
    assert_eq!(s.application, Ok(header));
    assert_eq!(check_image(iap, APP_SLOT, &BOARD), Ok(header));
    assert!(iap.entry().violations().is_empty());
}

#[test]
fn refused_files_get_foe_errors_and_the_repeat_works() {
    let mut r = Rig::new(true);
    r.boot_sms();
    r.request(0x03);
    let (mut file, _) = update_file("2.0.0");
    let last = file.len() - 1;
    file[last] ^= 1;
    let (code, text) = r.write_file(b"analog-io.efw", &file).unwrap_err();
    assert_eq!(code, FoeErrorCode::InvalidChecksum);
    assert_eq!(text, b"image CRC wrong");
    let (code, _) = r.write_file(b"readme.txt", b"x").unwrap_err();
    assert_eq!(code, FoeErrorCode::NotFound);
    // The repeat request gives the last answer again.
    r.esc.master_repeat_request();
    r.run();
    let again = r.esc.master_read_mailbox().expect("repeated");
    assert_eq!(&again[6..8], &[0x05, 0x00]);
    assert_eq!(r.slave.files().staged(), None);
}

#[test]
fn preop_from_the_bootloader() {
    let mut r = Rig::new(false);
    assert_eq!(r.request(0x02).0, (0x11, 0x0014), "no valid firmware");
    let mut r = Rig::new(true);
    let (status, out) = r.request(0x02);
    assert!(out.reset, "a valid application takes PREOP");
    assert_eq!(status, (0x01, 0));
}

#[test]
fn the_boot_request_from_before_the_reset_is_taken_at_start() {
    // The application saw INIT -> BOOT (and read AL control, which clears its event), then
    // reset into the bootloader: the request is only in the AL control register.
    let iap = Iap::new(FlashModel::new().with_cclk_khz(CCLK_KHZ), CCLK_KHZ);
    let mut esc = FakeEsc::new();
    let (out, inp) = BOOTSTRAP_MAILBOX;
    esc.master_sm(0, out.start, out.len, 0x26, true);
    esc.master_sm(1, inp.start, inp.len, 0x22, true);
    esc.master_al_control(0x03);
    esc.driver().read_al_control().unwrap();
    let mut slave = BootSlave::new(iap, BOARD, bootstrap(), true);
    assert!(!slave.start(&mut esc.driver()).unwrap().reset);
    assert_eq!(slave.state(), AlState::Bootstrap);
    assert_eq!(esc.al_status(), (0x03, 0));
}
