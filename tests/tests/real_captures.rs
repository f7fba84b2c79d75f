//! The CoE mailbox frames of real masters and slaves (TwinCAT, SOEM and ethercrab captures in
//! `../shared/vectors/captures`) decode with coe-core's wire layer and re-encode to the same
//! bytes (reserved bytes aside); the captures are read with the virtual board's pcapng reader.

use coe_core::wire::{
    Coe, CoeRepr, CoeService, Direction, Emergency, EmergencyRepr, Mailbox, MailboxRepr,
    MailboxType, Sdo, SdoInfo, SdoInfoRepr, SdoRepr,
};
use std::collections::BTreeSet;
use std::ops::Range;
use std::path::PathBuf;
use virtual_board::models::esc::parse_frame;
use virtual_board::tools::pcap::read_pcapng;

fn captures() -> Vec<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/vectors/captures");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "pcapng"))
        .collect();
    files.sort();
    files
}

/// Every distinct CoE mailbox frame in the datagrams of a capture.
fn coe_frames(packets: &[Vec<u8>]) -> BTreeSet<Vec<u8>> {
    let mut out = BTreeSet::new();
    for packet in packets {
        for d in parse_frame(packet).unwrap_or_default() {
            let Ok(m) = MailboxRepr::parse(&Mailbox::new_unchecked(&d.data[..])) else {
                continue;
            };
            let n = m.buffer_len();
            if m.mailbox_type == MailboxType::Coe && m.payload_len >= 2 && n <= d.data.len() {
                out.insert(d.data[..n].to_vec());
            }
        }
    }
    out
}

/// Decodes one CoE frame down to its service and re-encodes it; returns the service.
fn round_trip(frame: &[u8]) -> Result<CoeService, String> {
    let mbx = Mailbox::new_checked(frame).map_err(|e| format!("mailbox: {e:?}"))?;
    let header = MailboxRepr::parse(&mbx).map_err(|e| format!("mailbox: {e:?}"))?;
    let mut out = vec![0xA5u8; frame.len()];
    header
        .emit(&mut Mailbox::new_unchecked(&mut out[..]))
        .map_err(|e| format!("mailbox emit: {e:?}"))?;
    let payload = mbx.payload();
    let coe = CoeRepr::parse(&Coe::new_unchecked(payload)).map_err(|e| format!("CoE: {e:?}"))?;
    coe.emit(&mut Coe::new_unchecked(&mut out[6..]))
        .map_err(|e| format!("CoE emit: {e:?}"))?;
    let body = &payload[2..];
    let out_body = &mut out[8..];
    let n = match coe.service {
        CoeService::Emergency => {
            let r = EmergencyRepr::parse(&Emergency::new_unchecked(body))
                .map_err(|e| format!("emergency: {e:?}"))?;
            r.emit(&mut Emergency::new_unchecked(&mut *out_body))
                .map_err(|e| format!("emergency emit: {e:?}"))?;
            r.buffer_len()
        }
        CoeService::SdoInformation => {
            let r = SdoInfoRepr::parse(&SdoInfo::new_unchecked(body))
                .map_err(|e| format!("SDO Information: {e:?}"))?;
            r.emit(&mut SdoInfo::new_unchecked(&mut *out_body))
                .map_err(|e| format!("SDO Information emit: {e:?}"))?;
            r.buffer_len()
        }
        service => {
            let direction = Direction::from_service(service)
                .ok_or_else(|| format!("CoE service {service:?} not decoded here"))?;
            let r = SdoRepr::parse(&Sdo::new_unchecked(body), direction)
                .map_err(|e| format!("SDO: {e:?}"))?;
            r.emit(&mut Sdo::new_unchecked(&mut *out_body))
                .map_err(|e| format!("SDO emit: {e:?}"))?;
            // Reserved bytes are emitted as 0; masters and slaves leave whatever was in
            // their buffer there (one SOES-style slave echoes old data), so they are not
            // compared.
            let reserved = sdo_reserved(&r);
            out_body[reserved.clone()].copy_from_slice(&body[reserved]);
            r.buffer_len()
        }
    };
    let end = 8 + n;
    if out[..end] != frame[..end] {
        return Err(format!(
            "re-encoded differently:\n  captured {:02X?}\n  emitted  {:02X?}",
            &frame[..end],
            &out[..end]
        ));
    }
    Ok(coe.service)
}

/// The bytes of an SDO frame (after the CoE header) that carry nothing for `r`.
fn sdo_reserved(r: &SdoRepr) -> Range<usize> {
    match r {
        SdoRepr::InitiateDownloadResponse { .. } | SdoRepr::InitiateUploadRequest { .. } => 4..8,
        SdoRepr::DownloadSegmentResponse { .. } | SdoRepr::UploadSegmentRequest { .. } => 1..8,
        SdoRepr::DownloadSegmentRequest { data, .. }
        | SdoRepr::UploadSegmentResponse { data, .. } => (1 + data.len()).min(8)..8,
        _ => 0..0,
    }
}

#[test]
#[cfg_attr(
    not(has_shared_vectors),
    ignore = "needs the real captures in ../shared/vectors/captures"
)]
fn coe_frames_of_real_masters_decode_and_reencode_byte_identical() {
    let mut services = BTreeSet::new();
    let mut total = 0;
    for path in captures() {
        let bytes = std::fs::read(&path).unwrap();
        let packets = read_pcapng(&bytes)
            .unwrap_or_else(|| panic!("{}: not a pcapng capture", path.display()));
        assert!(!packets.is_empty(), "{}: no packets", path.display());
        for frame in coe_frames(&packets) {
            let service = round_trip(&frame).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            services.insert(format!("{service:?}"));
            total += 1;
        }
    }
    eprintln!("{total} distinct CoE frames, services {services:?}");
    assert!(total > 100, "the captures hold hundreds of CoE frames");
    // (No capture holds SDO Information or Emergency frames: tshark finds none either.)
    for needed in ["SdoRequest", "SdoResponse"] {
        assert!(
            services.contains(needed),
            "no {needed} frame in the captures"
        );
    }
}

#[test]
fn pcapng_reader_golden_bytes() {
    // Section header (little endian, version 1.0), an Ethernet interface, one enhanced
    // packet of 4 bytes, one simple packet of 2 bytes.
    #[rustfmt::skip]
    let capture: Vec<u8> = [
        &[0x0A, 0x0D, 0x0D, 0x0A, 28, 0, 0, 0, 0x4D, 0x3C, 0x2B, 0x1A, 1, 0, 0, 0][..],
        &[0xFF; 8], &[28, 0, 0, 0],
        &[1, 0, 0, 0, 20, 0, 0, 0, 1, 0, 0, 0, 0xFF, 0xFF, 0, 0, 20, 0, 0, 0],
        &[6, 0, 0, 0, 36, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 4, 0, 0, 0, 4, 0, 0, 0],
        &[0xDE, 0xAD, 0xBE, 0xEF, 36, 0, 0, 0],
        &[3, 0, 0, 0, 20, 0, 0, 0, 2, 0, 0, 0, 0x88, 0xA4, 0, 0, 20, 0, 0, 0],
    ]
    .concat();
    assert_eq!(
        read_pcapng(&capture),
        Some(vec![vec![0xDE, 0xAD, 0xBE, 0xEF], vec![0x88, 0xA4]])
    );
    // A block that runs past the end, and a classic pcap, are not read.
    assert_eq!(read_pcapng(&capture[..capture.len() - 4]), None);
    assert_eq!(read_pcapng(&0xA1B2_3C4Du32.to_le_bytes()), None);
}
