//! The analog I/O: the AD7689's samples to the master, the master's values to the AD5663
//! at SYNC0, and the CiA 401 objects behind them.

pub mod adc_dma;
pub mod adc_scan;
pub mod dac;
pub mod objects;
pub mod outputs;
pub mod process_data;
pub mod sampler;
pub mod scaling;
