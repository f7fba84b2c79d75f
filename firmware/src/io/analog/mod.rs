//! The analog I/O: the AD7689's samples to the master, the master's values to the AD5663
//! at SYNC0, and the CiA 401 objects behind them ([`objects::AnalogIo`], the application
//! the analog products run).
//!
//! | module           | what                                                               |
//! |------------------|--------------------------------------------------------------------|
//! | [`objects`]      | the application: object values, write rules, what the EtherCAT slave application asks of it |
//! | [`process_data`] | PDO mapping and assignment, the images, the fast copy per cycle    |
//! | [`outputs`]      | outputs staged for the SYNC0 (DAC) task, latched there; the fault reaction |
//! | [`dac`]          | the AD5663 as the DAC task drives it                               |
//! | [`dac_pair`]     | the codes of both outputs in one word                              |
//! | [`sampler`]      | the samples between the ADC path and the process data              |
//! | [`adc_dma`]      | the PDI task's side of the GPDMA ring of scans                     |
//! | [`block_assignment`] | the order rule both oversampling assignments share            |
//! | [`oversampling`] | input oversampling: the sample blocks cut from the ring at DC times |
//! | [`output_blocks`] | output oversampling: update blocks, their admission, the hand-over to the update interrupt, the LDAC grid's lock |
//! | [`scaling`]      | codes <-> process values <-> volts                                 |
//! | [`settings`]     | the manufacturer settings object (AI filter)                        |

pub mod adc_dma;
pub mod block_assignment;
pub mod dac;
pub mod dac_pair;
pub mod objects;
pub mod output_blocks;
pub mod outputs;
pub mod oversampling;
pub mod process_data;
pub mod sampler;
pub mod scaling;
pub mod settings;

pub use crate::platform::board::{AI_CHANNELS, AO_CHANNELS};
pub use objects::{AnalogApplication, AnalogIo};
pub use settings::{AI_FILTER_AVERAGE, AI_FILTER_LATEST, SETTINGS_INDEX};
