//! Peers: other slave stacks on the same co-simulated board, driven by the same masters and
//! measured by the same bench (issue 29). The only one is SOES ([`soes`]), built from
//! `../shared/peers/soes` with the port in `tests/soes`.

pub mod esi;
pub mod soes;
