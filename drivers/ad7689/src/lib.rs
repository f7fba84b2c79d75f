//! Driver for the ad7689.
#![no_std]
#![forbid(unsafe_code)]
