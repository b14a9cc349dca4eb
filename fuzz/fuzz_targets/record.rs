//! Format detection plus whichever reader it picks, on arbitrary bytes; and
//! the FRF reader (content kind, UFF58 types 4/6 or CSV) on the same bytes.
#![no_main]

use std::path::Path;

use records::{FrfReadOptions, ReadOptions, content_kind, parse_frf, parse_record};
use libfuzzer_sys::fuzz_target;

mod common;

fuzz_target!(|data: &[u8]| {
    match parse_record(data, Path::new("fuzz.dat"), &ReadOptions::default()) {
        Ok(rec) => common::check_clean(&rec),
        Err(e) => assert!(!e.to_string().is_empty()),
    }
    let _ = content_kind(data);
    match parse_frf(data, Path::new("fuzz.dat"), &FrfReadOptions::default()) {
        // An accepted FRF file is one the writers take back.
        Ok(file) => assert_eq!(file.consistency_problem(), None),
        Err(e) => assert!(!e.to_string().is_empty()),
    }
});
