//! The products.

pub mod analog_io;
