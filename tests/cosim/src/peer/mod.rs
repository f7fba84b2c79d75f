//! Peers: other slave stacks on the same co-simulated board, driven by the same masters and
//! measured by the same bench (issue 29). The only one is SOES ([`soes`]), built from
//! `../shared/peers/soes` with the port in `tests/soes`.

pub mod bench;
pub mod conformance;
pub mod esi;
pub mod soes;

use crate::bench::{Plan, Program};
use crate::image::Image;
use bench::SdoRequest;
use conformance::Profile;
use virtual_board::tools::peer_figures::PeerFigures;

/// The SDO requests of the service-time rows on this project's image: an upload of
/// 0x1018:02 and a 4-byte download to 0x6444:01 (a fault value).
pub const OURS_SDO: [SdoRequest; 2] = [
    SdoRequest::Upload(0x1018, 2),
    SdoRequest::Download(0x6444, 1, [0, 0, 0, 0]),
];
/// The same on SOES: 0x1018:02 and 0x10F1:01 (its 32-bit writable object).
pub const SOES_SDO: [SdoRequest; 2] = [
    SdoRequest::Upload(0x1018, 2),
    SdoRequest::Download(0x10F1, 1, [0, 0, 0, 0]),
];
/// The conformance profile of this project's image.
pub const OURS_PROFILE: Profile = Profile {
    writable_u32: (0x6444, 1),
};
/// The conformance profile of SOES.
pub const SOES_PROFILE: Profile = Profile {
    writable_u32: (0x10F1, 1),
};

/// The conformance verdicts of both stacks, as table rows.
pub fn conformance_rows(
    ours: &Image,
    soes: &Image,
) -> Result<Vec<virtual_board::tools::peer_figures::ConformanceRow>, String> {
    let a = conformance::run_all(&Program::release(ours), &OURS_PROFILE);
    let b = conformance::run_all(&soes::program(soes)?, &SOES_PROFILE);
    Ok(conformance::rows(a, b))
}

/// Everything `cargo xtask bench --peer soes` shows: both stacks' figures and the
/// conformance table.
pub fn measure(
    ours: &Image,
    ours_elf: &str,
    peer: &Image,
    peer_elf: &str,
    quick: bool,
    progress: &mut dyn FnMut(&str),
) -> Result<PeerFigures, String> {
    let plan = Plan::new(quick);
    let ours_figures = bench::measure_stack(
        "this project (release image)",
        ours_elf,
        &Program::release(ours),
        OURS_SDO,
        &plan,
        progress,
    )?;
    let peer_figures = bench::measure_stack(
        "SOES",
        peer_elf,
        &soes::program(peer)?,
        SOES_SDO,
        &plan,
        progress,
    )?;
    progress("conformance checks");
    Ok(PeerFigures {
        quick,
        peer_name: "SOES".into(),
        ours: ours_figures,
        peer: peer_figures,
        conformance: conformance_rows(ours, peer)?,
    })
}
