//! What the products do with the board's converters.
//!
//! | module     | what                                                                     |
//! |------------|--------------------------------------------------------------------------|
//! | [`analog`] | 8 analog inputs (AD7689) and 2 analog outputs (AD5663): sampling, staging for SYNC0, scaling, the CiA 401 objects and process data |

pub mod analog;
