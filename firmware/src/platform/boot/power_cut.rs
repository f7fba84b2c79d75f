//! The bootloader's update path against the flash/IAP model of `lpc17xx-iap`, with a master's
//! FoE transfer through coe-core's FoE server: good updates, bad files, boot requests, and
//! the POWER-CUT test, which cuts the power at every erase and program step of an update
//! (the download into the staging area and the installation at the next reset), with every
//! cut effect, reboots, and updates again.

use super::header::{HeaderRepr, Target};

/// The board the tests' bootloader runs on, and the files built for it.
const BOARD: Board = THESIS;
const UPDATE_TARGET: Target = Target::new(BOARD.vendor_id, 0x1754, &BOARD, Options::NONE);
use super::install::{check_image, startup, Invalid, Startup, Stay};
use super::layout::{APP_SLOT, BOOTLOADER, STAGING};
use super::staging::StagingWriter;
use crate::platform::board::{Board, Options, THESIS};
use coe_core::foe::FoeServer;
use coe_core::wire::{Foe, FoeErrorCode, FoeRepr};
use coe_core::AlState;
use lpc17xx_iap::model::{CutEffect, FlashModel};
use lpc17xx_iap::Iap;
use std::string::String;
use std::vec::Vec;

/// The CPU clock the bootloader tells the ROM (and the model checks).
const CCLK_KHZ: u32 = 100_000;
/// The bootstrap mailbox size the transfers use.
const MBX: usize = 128;

type Writer = StagingWriter<FlashModel>;

fn image(len: usize, seed: u32) -> Vec<u8> {
    let mut x = seed.wrapping_mul(2_654_435_761).wrapping_add(1);
    (0..len)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x as u8
        })
        .collect()
}

/// An update file: header block for `target`, then `image`.
fn file(image: &[u8], target: &Target, version: &str) -> Vec<u8> {
    let mut f = HeaderRepr::for_image(image, target, version)
        .to_bytes()
        .to_vec();
    f.extend_from_slice(image);
    f
}

/// A module whose bootloader region holds a pattern and whose slot holds `installed`.
fn module(installed: &[u8]) -> FlashModel {
    let mut m = FlashModel::new().with_cclk_khz(CCLK_KHZ);
    m.load(BOOTLOADER.start, &image(BOOTLOADER.len as usize, 99));
    m.load(APP_SLOT.start, installed);
    m
}

fn writer(model: FlashModel) -> Writer {
    StagingWriter::new(Iap::new(model, CCLK_KHZ), BOARD)
}

/// An FoE error as the master sees it.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Refused {
    code: FoeErrorCode,
    text: String,
    /// The packet it answered (0: the write request).
    packet: u32,
}

/// A master's FoE write of `content` as `name` through a mailbox of [`MBX`] bytes: what
/// SOEM's `ec_FOEwrite` does (BUSY repeats the packet, an error ends it).
fn foe_write(
    server: &mut FoeServer,
    writer: &mut Writer,
    name: &[u8],
    content: &[u8],
    state: AlState,
) -> Result<(), Refused> {
    let room = MBX - 12;
    let mut out = [0u8; MBX - 6];
    let mut send = |server: &mut FoeServer, writer: &mut Writer, p: FoeRepr<'_>, number: u32| {
        let mut packet = std::vec![0u8; p.buffer_len()];
        p.emit(&mut Foe::new_unchecked(&mut packet[..])).unwrap();
        let n = server
            .process(&packet, MBX, state, writer, 0, &mut out)
            .unwrap()
            .expect("every packet is answered");
        match FoeRepr::parse(&Foe::new_unchecked(&out[..n])).unwrap() {
            FoeRepr::Ack { packet_number } => {
                assert_eq!(packet_number, number);
                Ok(())
            }
            FoeRepr::Error { code, text } => Err(Refused {
                code,
                text: String::from_utf8(text.to_vec()).unwrap(),
                packet: number,
            }),
            other => panic!("{other:?}"),
        }
    };
    send(
        server,
        writer,
        FoeRepr::WriteRequest {
            password: 0,
            file_name: name,
        },
        0,
    )?;
    let mut chunks: Vec<&[u8]> = content.chunks(room).collect();
    if content.len() % room == 0 {
        chunks.push(&[]);
    }
    for (i, data) in chunks.into_iter().enumerate() {
        let number = i as u32 + 1;
        send(
            server,
            writer,
            FoeRepr::Data {
                packet_number: number,
                data,
            },
            number,
        )?;
    }
    Ok(())
}

fn update(writer: &mut Writer, content: &[u8]) -> Result<(), Refused> {
    foe_write(
        &mut FoeServer::new(),
        writer,
        b"analog-io-0.2.0.efw",
        content,
        AlState::Bootstrap,
    )
}

fn reset(writer: Writer, requested: bool) -> (Startup, FlashModel) {
    let mut iap = writer.into_iap();
    iap.entry_mut().power_on();
    let s = startup(&mut iap, &BOARD, requested);
    (s, iap.into_entry())
}

fn slot_header(model: &FlashModel, region: super::layout::Region) -> Result<HeaderRepr, Invalid> {
    check_image(&Iap::new(model.clone(), CCLK_KHZ), region, &BOARD)
}

fn old() -> (Vec<u8>, HeaderRepr) {
    let f = file(&image(30_000, 1), &UPDATE_TARGET, "0.1.0");
    let h = HeaderRepr::for_image(&f[256..], &UPDATE_TARGET, "0.1.0");
    (f, h)
}

fn new() -> (Vec<u8>, HeaderRepr) {
    let f = file(&image(21_000, 2), &UPDATE_TARGET, "0.2.0");
    let h = HeaderRepr::for_image(&f[256..], &UPDATE_TARGET, "0.2.0");
    (f, h)
}

#[test]
fn an_update_is_staged_then_installed_at_the_next_reset() {
    let (old_file, old_header) = old();
    let (new_file, new_header) = new();
    let mut w = writer(module(&old_file));
    update(&mut w, &new_file).unwrap();
    assert_eq!(w.staged(), Some(&new_header));
    let model = w.iap_mut().entry().clone();
    assert_eq!(
        slot_header(&model, APP_SLOT),
        Ok(old_header),
        "not touched yet"
    );
    assert_eq!(slot_header(&model, STAGING), Ok(new_header));

    let (s, model) = reset(w, false);
    assert!(s.installed);
    assert_eq!(s.install_error, None);
    assert_eq!(s.application, Ok(new_header));
    assert_eq!(s.stay, None, "the new application starts");
    assert_eq!(
        &model.flash()[APP_SLOT.start as usize..][..new_file.len()],
        &new_file[..]
    );
    assert!(
        matches!(slot_header(&model, STAGING), Err(Invalid::Header(_))),
        "the staging area is erased once installed"
    );
    assert!(model.violations().is_empty(), "{:?}", model.violations());
    // The next reset starts it without installing again.
    let (s, _) = reset(writer(model), false);
    assert!(!s.installed);
    assert_eq!((s.application, s.stay), (Ok(new_header), None));
}

#[test]
fn bad_files_are_refused_and_the_old_application_stays() {
    let (old_file, old_header) = old();
    let img = image(9_000, 3);
    let other_board = Target {
        board: UPDATE_TARGET.board + 1,
        ..UPDATE_TARGET
    };
    let needs_can = Target {
        needs: Options::CAN_TRANSCEIVER,
        ..UPDATE_TARGET
    };
    let other_revision = Target {
        hardware_revision: UPDATE_TARGET.hardware_revision + 1,
        ..UPDATE_TARGET
    };
    let other_vendor = Target {
        vendor_id: UPDATE_TARGET.vendor_id + 2,
        ..UPDATE_TARGET
    };
    let good = file(&img, &UPDATE_TARGET, "9.9.9");
    let mut bad_crc = good.clone();
    bad_crc[5000] ^= 0x40;
    let mut too_large = HeaderRepr::for_image(&img, &UPDATE_TARGET, "9.9.9");
    too_large.image_len = APP_SLOT.len;
    let mut too_large = too_large.to_bytes().to_vec();
    too_large.extend_from_slice(&img);
    let cases: [(&str, Vec<u8>, FoeErrorCode, &str); 9] = [
        (
            "another board",
            file(&img, &other_board, "9.9.9"),
            FoeErrorCode::InvalidFirmware,
            "other board",
        ),
        (
            "a product that needs the CAN transceiver",
            file(&img, &needs_can, "9.9.9"),
            FoeErrorCode::InvalidFirmware,
            "board lacks a part",
        ),
        (
            "another hardware revision",
            file(&img, &other_revision, "9.9.9"),
            FoeErrorCode::InvalidFirmware,
            "other hardware revision",
        ),
        (
            "another vendor",
            file(&img, &other_vendor, "9.9.9"),
            FoeErrorCode::InvalidFirmware,
            "other vendor ID",
        ),
        (
            "bad CRC",
            bad_crc,
            FoeErrorCode::InvalidChecksum,
            "image CRC wrong",
        ),
        (
            "truncated",
            good[..good.len() - 700].to_vec(),
            FoeErrorCode::InvalidChecksum,
            "truncated",
        ),
        (
            "truncated in the header",
            good[..200].to_vec(),
            FoeErrorCode::NoFileHeader,
            "shorter than the header",
        ),
        (
            "no header",
            img.clone(),
            FoeErrorCode::NoFileHeader,
            "not an .efw file",
        ),
        (
            "too large",
            too_large,
            FoeErrorCode::DiskFull,
            "image too large",
        ),
    ];
    for (what, content, code, text) in cases {
        let mut w = writer(module(&old_file));
        let e = update(&mut w, &content).unwrap_err();
        assert_eq!((e.code, e.text.as_str()), (code, text), "{what}");
        assert_eq!(w.staged(), None, "{what}");
        let (s, model) = reset(w, false);
        assert!(!s.installed, "{what}");
        assert_eq!(
            s.application,
            Ok(old_header),
            "{what}: the old application stays"
        );
        assert_eq!(s.stay, None, "{what}: and starts");
        assert_eq!(
            &model.flash()[APP_SLOT.start as usize..][..old_file.len()],
            &old_file[..],
            "{what}"
        );
    }
    // A longer file than the header says: refused at the first byte too many.
    let mut longer = good.clone();
    longer.extend_from_slice(&[0; 300]);
    let e = update(&mut writer(module(&old_file)), &longer).unwrap_err();
    assert_eq!(e.code, FoeErrorCode::DiskFull);
    assert_eq!(e.text, "longer than the header says");
}

#[test]
fn name_password_and_state_are_checked_before_anything_is_written() {
    let (old_file, _) = old();
    let (new_file, _) = new();
    let mut w = writer(module(&old_file));
    let mut server = FoeServer::new();
    let e = foe_write(
        &mut server,
        &mut w,
        b"analog-io.bin",
        &new_file,
        AlState::Bootstrap,
    )
    .unwrap_err();
    assert_eq!((e.code, e.packet), (FoeErrorCode::NotFound, 0));
    let e = foe_write(&mut server, &mut w, b"x.efw", &new_file, AlState::PreOp).unwrap_err();
    assert_eq!(e.code, FoeErrorCode::BootstrapOnly);
    let mut wrq = std::vec![0u8; 11];
    FoeRepr::WriteRequest {
        password: 1,
        file_name: b"x.efw",
    }
    .emit(&mut Foe::new_unchecked(&mut wrq[..]))
    .unwrap();
    let mut out = [0u8; 64];
    let n = server
        .process(&wrq, MBX, AlState::Bootstrap, &mut w, 0, &mut out)
        .unwrap()
        .unwrap();
    assert_eq!(
        FoeRepr::parse(&Foe::new_unchecked(&out[..n])).unwrap(),
        FoeRepr::Error {
            code: FoeErrorCode::NoRights,
            text: b"wrong password"
        }
    );
    // Upper case and the bare suffix.
    assert!(super::staging::is_firmware_name(b"FIRMWARE.EFW"));
    assert!(!super::staging::is_firmware_name(b".efw"));
    assert_eq!(
        w.iap_mut().entry().steps(),
        0,
        "nothing erased or programmed"
    );
}

#[test]
fn the_bootloader_stays_when_asked_or_without_an_application() {
    let (old_file, old_header) = old();
    let (s, _) = reset(writer(module(&old_file)), true);
    assert_eq!(s.stay, Some(Stay::Requested));
    assert_eq!(s.application, Ok(old_header));
    let (s, _) = reset(writer(module(&[])), false);
    assert_eq!(
        s.stay,
        Some(Stay::NoApplication(Invalid::Header(
            super::header::HeaderError::BadMagic
        )))
    );
    // An application whose image is damaged.
    let mut damaged = old_file.clone();
    damaged[20_000] ^= 1;
    let (s, _) = reset(writer(module(&damaged)), false);
    assert_eq!(s.stay, Some(Stay::NoApplication(Invalid::Crc)));
}

/// One update from `start`: FoE download, then the reset that installs. Returns the model
/// and whether the power was cut on the way (it is back on at the end).
fn update_and_reset(model: FlashModel, content: &[u8]) -> (FlashModel, Option<Startup>) {
    let mut w = writer(model);
    let downloaded = update(&mut w, content).is_ok();
    let mut iap = w.into_iap();
    if !iap.entry().powered() {
        return (iap.into_entry(), None);
    }
    assert!(downloaded, "without a cut the download succeeds");
    let s = startup(&mut iap, &BOARD, false);
    let cut = !iap.entry().powered();
    (iap.into_entry(), (!cut).then_some(s))
}

/// The reset sequence without a master after a cut (cut again at `second`, if given): the
/// flash it leaves (the power back on), and its outcome unless the power failed during it.
fn reboot(
    mut model: FlashModel,
    second: Option<(u64, CutEffect)>,
) -> (FlashModel, Option<Startup>) {
    model.power_on();
    if let Some((at, effect)) = second {
        model.cut_power_at(at, effect);
    }
    let mut iap = Iap::new(model, CCLK_KHZ);
    let s = startup(&mut iap, &BOARD, false);
    let mut model = iap.into_entry();
    let cut = !model.powered();
    model.power_on();
    (model, (!cut).then_some(s))
}

/// Boots without a master until a reset sequence runs to its end (a reboot cut at
/// `second` is followed by one that is not): which application starts.
fn boot_alone(model: FlashModel, second: Option<(u64, CutEffect)>) -> (FlashModel, Startup) {
    match reboot(model, second) {
        (model, Some(s)) => (model, s),
        (model, None) => match reboot(model, None) {
            (model, Some(s)) => (model, s),
            (_, None) => unreachable!("no cut was set"),
        },
    }
}

#[test]
fn power_cut_at_every_erase_and_program_step() {
    let (old_file, old_header) = old();
    let (new_file, new_header) = new();
    let bootloader = image(BOOTLOADER.len as usize, 99);

    // The steps of one uncut update, and of its download alone.
    let (done, s) = update_and_reset(module(&old_file), &new_file);
    assert_eq!(
        s.map(|s| (s.application, s.stay)),
        Some((Ok(new_header), None))
    );
    let total = done.steps();
    let mut w = writer(module(&old_file));
    update(&mut w, &new_file).unwrap();
    let download = w.iap_mut().entry().steps();
    assert!(
        download > 10 && total > download + 10,
        "{download} of {total}"
    );

    let mut cuts = 0u64;
    let mut double_cuts = 0u64;
    let mut installs_completed = 0u64;
    for effect in CutEffect::ALL {
        for k in 0..total {
            let mut model = module(&old_file);
            model.cut_power_at(k, effect);
            let (model, s) = update_and_reset(model, &new_file);
            assert!(s.is_none(), "step {k} was cut");
            cuts += 1;
            assert_eq!(&model.flash()[..bootloader.len()], &bootloader[..]);
            if k < download {
                assert_eq!(
                    slot_header(&model, APP_SLOT),
                    Ok(old_header),
                    "cut {effect:?} at download step {k}: the old application is intact"
                );
            }
            // Reboot without a master, cut again at every step of the reset sequence (or not
            // at all): an application starts by itself, the new one once its download was
            // whole (a cut installation completes at the next boot), never the bootloader
            // waiting for a master. Then the master updates again: it must succeed every time.
            let steps_of_reboot = {
                let (m, _) = reboot(model.clone(), None);
                m.steps() - model.steps()
            };
            for second in
                core::iter::once(None).chain((0..steps_of_reboot).map(|j| Some((j, effect))))
            {
                let (rebooted, s) = boot_alone(model.clone(), second);
                if second.is_some() {
                    double_cuts += 1;
                }
                assert_eq!(&rebooted.flash()[..bootloader.len()], &bootloader[..]);
                assert_eq!(
                    s.stay, None,
                    "cut {effect:?} at step {k}, then {second:?}: {s:?}"
                );
                if k >= download {
                    installs_completed += 1;
                    assert_eq!(
                        s.application,
                        Ok(new_header),
                        "cut {effect:?} at installation step {} of {}, then {second:?}: the \
                         installation completes without a master",
                        k - download,
                        total - download
                    );
                } else {
                    assert!(
                        s.application == Ok(old_header) || s.application == Ok(new_header),
                        "cut {effect:?} at download step {k}, then {second:?}: {s:?}"
                    );
                }
                let (after, s) = update_and_reset(rebooted, &new_file);
                assert_eq!(
                    s.map(|s| (s.application, s.stay)),
                    Some((Ok(new_header), None)),
                    "cut {effect:?} at step {k}, then {second:?}: the update again succeeds"
                );
                assert_eq!(&after.flash()[..bootloader.len()], &bootloader[..]);
                assert!(after.violations().is_empty(), "{:?}", after.violations());
            }
        }
    }
    std::println!(
        "power-cut test: {total} erase/program steps per update ({download} in the download), \
         {cuts} single cuts ({} effects x {total} steps) and {double_cuts} second cuts during \
         the reboot; an application started without a master after every one, the new one \
         in all {installs_completed} boots after a cut installation; the update succeeded \
         after every one",
        CutEffect::ALL.len()
    );
    assert_eq!(cuts, 3 * total);
}
