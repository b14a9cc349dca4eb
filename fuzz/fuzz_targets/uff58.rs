//! UFF dataset-58 reader (ASCII and binary) on arbitrary bytes.
#![no_main]

use std::path::Path;

use records::{ReadOptions, parse_uff58};
use libfuzzer_sys::fuzz_target;

mod common;

fuzz_target!(|data: &[u8]| {
    for opts in [ReadOptions::default(), ReadOptions::with_fs_hz(1000.0)] {
        match parse_uff58(data, Path::new("fuzz.uff"), &opts) {
            Ok(rec) => common::check_clean(&rec),
            Err(e) => assert!(!e.to_string().is_empty()),
        }
    }
});
