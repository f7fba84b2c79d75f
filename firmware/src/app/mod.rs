//! The slave application: everything between the ESC registers, the converters and the
//! CoE core that does not depend on the MCU.

pub mod esc;
pub mod esm;
pub mod outputs;
pub mod sampler;
pub mod scaling;
pub mod sync;
