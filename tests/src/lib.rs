//! Virtual board: models of the ET1100, AD5663 and AD7689 on the host, and a rig that
//! lets a real EtherCAT master (ethercrab) drive them in-process.
//!
//! - [`esc::Esc`]: the ET1100 (frames with every datagram command and its working
//!   counter, registers with per-side write masks, 8 FMMUs, 8 SyncManagers in mailbox and
//!   3-buffer mode, AL control/status and events, SII EEPROM interface, DC with SYNC0/1,
//!   process-data watchdog), driven by virtual time ([`esc::Esc::advance`]).
//! - [`spi::EscSpi`]: the ESC's SPI PDI as an `embedded_hal::spi::SpiDevice<u8>`,
//!   byte-exact, with [`spi::SpiStats`] counters.
//! - [`dac::DacSpi`]/[`dac::LdacPin`] on [`dac::Ad5663`], [`adc::AdcSpi`] on
//!   [`adc::Ad7689`] with per-channel [`adc::Signal`] sources.
//! - [`board::VirtualBoard`]: ESC + DAC + ADC + [`clock::Clock`] + [`pcap::PcapWriter`],
//!   with the firmware plugged in as a [`board::PdiCpu`].
//! - [`master::tx_rx_task`]: ethercrab's PDU loop wired to a board.
//! - [`sdo_client`]: raw mailbox access as a master does it, and an SDO upload client on it
//!   (segmented uploads, which ethercrab 0.7.1 cannot take).
//! - [`sii_builder`]: a tiny SII image builder for the ESC model tests (the firmware's
//!   image is generated from its description, [`sim::firmware_device`]).
//!
//! Time: nothing here reads the wall clock. Each frame advances the board's virtual
//! time by its wire time plus a configurable gap; SYNC edges, EEPROM busy time, the
//! watchdog and ADC sampling all use that time.

pub mod adc;
pub mod board;
pub mod bus_cost;
pub mod clock;
pub mod dac;
pub mod esc;
pub mod firmware_cpu;
pub mod iface;
pub mod loopback;
pub mod master;
pub mod pcap;
pub mod sdo_client;
pub mod sii_builder;
pub mod sim;
pub mod spi;
