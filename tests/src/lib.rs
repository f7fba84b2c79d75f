//! Virtual board: models of the ET1100, AD5663 and AD7689 on the host, and a rig that
//! lets a real EtherCAT master (ethercrab) drive them in-process.
//!
//! Three groups:
//! - [`models`]: the chips, each read from its datasheet.
//!   - [`models::esc::Esc`]: the ET1100 (frames with every datagram command and its working
//!     counter, registers with per-side write masks, 8 FMMUs, 8 SyncManagers in mailbox and
//!     3-buffer mode, AL control/status and events, SII EEPROM interface, DC with SYNC0/1,
//!     process-data watchdog), driven by virtual time ([`models::esc::Esc::advance`]).
//!   - [`models::spi::EscSpi`]: the ESC's SPI PDI as an `embedded_hal::spi::SpiDevice<u8>`,
//!     byte-exact, with [`models::spi::SpiStats`] counters.
//!   - [`models::dac::DacSpi`]/[`models::dac::LdacPin`] on [`models::dac::Ad5663`],
//!     [`models::adc::AdcSpi`] on [`models::adc::Ad7689`] with per-channel
//!     [`models::adc::Signal`] sources.
//!   - [`models::can::CanBus`]: the CAN bus (arbitration, frame times at the bit rate) with
//!     the MCU's CAN controller and any other node on ports.
//! - [`rig`]: what puts the models to work in a test.
//!   - [`rig::board::VirtualBoard`]: ESC + DAC + ADC + [`rig::clock::Clock`] +
//!     [`tools::pcap::PcapWriter`], with the firmware plugged in as a [`rig::board::PdiCpu`].
//!   - [`rig::firmware_cpu::FirmwareCpu`]: the firmware's tasks on the models.
//!   - [`rig::master::tx_rx_task`]: ethercrab's PDU loop wired to a board.
//!   - [`rig::can_master::CanMaster`]: a CANopen master in process on the board's CAN bus
//!     (NMT, SYNC, SDO client).
//!   - [`rig::master_host`]: coe-core's CANopen master on a bus port, and a network of it
//!     and in-process slaves ([`rig::can_slave`]: coe-core's CAN node on a generic I/O and
//!     CiA 402-like device) in virtual time.
//!   - [`rig::sdo_client`]: raw mailbox access as a master does it, and an SDO client on
//!     it (segmented transfers, which ethercrab 0.7.1 cannot do), on ethercrab or on the
//!     scripted master.
//!   - [`rig::scripted::ScriptedMaster`]: a synchronous master that walks the ESM, runs the
//!     mailbox and the process data one datagram at a time, and breaks the network on
//!     purpose (cable pulled, frames lost or repeated) for the fault tests.
//!   - [`rig::foe_client`]: the walk to BOOT on the bootstrap mailbox and an FoE client
//!     (ethercrab 0.7.1 has neither).
//!   - [`rig::module_cpu`]: the module as shipped, bootloader and application on one CPU
//!     and one flash model, with the reset sequence between them.
//!   - [`rig::sii_builder`]: a tiny SII image builder for the ESC model tests (the
//!     firmware's image is generated from its description, [`tools::sim::firmware_device`]).
//! - [`tools`]: what `cargo xtask` runs on the board: the simulation ([`tools::sim`], also
//!   on a network interface, [`tools::iface`]), the PDI bus cost ([`tools::bus_cost`]), the
//!   thesis loop-back ([`tools::loopback`]), the pcap writer ([`tools::pcap`]), the format
//!   of the image co-simulator's bench figures ([`tools::image_figures`]) and the socketcand
//!   server that brings the CAN bus to python-can ([`tools::socketcand`]), and the checks of
//!   a master's analog process data against the converters ([`tools::analog_check`]).
//!
//! Time: in process nothing reads the wall clock. Each frame advances the board's virtual
//! time by its wire time plus a configurable gap; SYNC edges, EEPROM busy time, the
//! watchdog and ADC sampling all use that time. On a network interface
//! ([`tools::iface`]) the ESC keeps the wall clock's time and the CPU's virtual time is
//! stepped towards it ([`models::shared_esc`]).

/// The chips: ET1100 (with its SPI front end), AD5663, AD7689.
pub mod models {
    pub mod adc;
    pub mod can;
    pub mod dac;
    pub mod esc;
    pub mod shared_esc;
    pub mod spi;
}

/// The test rig: board, clock, the firmware as the board's CPU, the master side.
pub mod rig {
    pub mod board;
    pub mod can_master;
    pub mod can_slave;
    pub mod clock;
    pub mod firmware_cpu;
    pub mod foe_client;
    pub mod gateway_cpu;
    pub mod master;
    pub mod master_host;
    pub mod module_cpu;
    pub mod pi_mutex;
    pub mod scripted;
    pub mod sdo_client;
    pub mod sii_builder;
}

/// What `cargo xtask` runs on the board.
pub mod tools {
    pub mod analog_check;
    pub mod bus_cost;
    pub mod dwarf;
    pub mod iface;
    pub mod image_figures;
    pub mod latency;
    pub mod loopback;
    pub mod pcap;
    pub mod peer_figures;
    pub mod sim;
    pub mod socketcand;
}
