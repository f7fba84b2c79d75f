//! Driver for the ad5663.
#![no_std]
#![forbid(unsafe_code)]
