//! CSV reader on arbitrary bytes, with and without a sampling rate.
#![no_main]

use std::path::Path;

use records::{ReadOptions, parse_csv};
use libfuzzer_sys::fuzz_target;

mod common;

fuzz_target!(|data: &[u8]| {
    for opts in [ReadOptions::default(), ReadOptions::with_fs_hz(1000.0)] {
        match parse_csv(data, Path::new("fuzz.csv"), &opts) {
            Ok(rec) => common::check_clean(&rec),
            Err(e) => assert!(!e.to_string().is_empty()),
        }
    }
});
