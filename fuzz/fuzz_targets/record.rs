//! Format detection plus whichever reader it picks, on arbitrary bytes.
#![no_main]

use std::path::Path;

use records::{ReadOptions, parse_record};
use libfuzzer_sys::fuzz_target;

mod common;

fuzz_target!(|data: &[u8]| {
    match parse_record(data, Path::new("fuzz.dat"), &ReadOptions::default()) {
        Ok(rec) => common::check_clean(&rec),
        Err(e) => assert!(!e.to_string().is_empty()),
    }
});
