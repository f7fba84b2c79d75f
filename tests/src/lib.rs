//! Virtual board: models of the ET1100, AD5663 and AD7689 on the host, and a rig that
//! lets a real EtherCAT master (ethercrab) drive them in-process.

pub mod adc;
pub mod board;
pub mod clock;
pub mod dac;
pub mod esc;
pub mod master;
pub mod pcap;
pub mod sii_builder;
pub mod spi;
