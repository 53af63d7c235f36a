//! Fuzz Bonfiglioli Modbus ASCII framing: whole-frame decoding and drive-core's receiver with
//! `ModbusFraming` on both sides (the body is `bonfiglioli_common.rs`, shared with the other
//! mode).
//!
//! `cargo fuzz run bonfiglioli_ascii` (from the `fuzz/` folder), or `scripts/fuzz`.
#![no_main]

#[path = "bonfiglioli_common.rs"]
mod common;

use bonfiglioli_modbus::framing::Mode;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| common::run(Mode::Ascii, data));
