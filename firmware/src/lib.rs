//! The slave application of the analog I/O module, independent of the MCU.
#![no_std]
#![forbid(unsafe_code)]
