//! Driver for the et1100.
#![no_std]
#![forbid(unsafe_code)]
