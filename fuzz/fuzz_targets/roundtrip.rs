//! Whatever a reader accepts, the writers either refuse with a reason or
//! write something that reads back unchanged: values and times bit for bit
//! (CSV: the interval to 1e-9), names, units, nodes and directions.
#![no_main]

use std::path::Path;

use records::{
    ReadOptions, RecordError, RecordFile, Uff58Encoding, Csv, FileFormat, Uff58, parse_record,
};
use libfuzzer_sys::fuzz_target;

mod common;

fn same(a: &RecordFile, b: &RecordFile, exact_dt: bool, dof: bool) {
    assert_eq!(a.len(), b.len());
    assert_eq!(a.start_s.to_bits(), b.start_s.to_bits());
    if exact_dt {
        assert_eq!(a.dt_s.to_bits(), b.dt_s.to_bits());
    } else {
        assert!(
            (a.dt_s - b.dt_s).abs() <= 1e-9 * a.dt_s,
            "{} {}",
            a.dt_s,
            b.dt_s
        );
    }
    assert_eq!(a.channels.len(), b.channels.len());
    for (x, y) in a.channels.iter().zip(&b.channels) {
        assert_eq!(x.name, y.name);
        assert_eq!(x.unit, y.unit);
        if dof {
            assert_eq!(x.node.unwrap_or(0), y.node.unwrap_or(0));
            assert_eq!(x.direction.unwrap_or(0), y.direction.unwrap_or(0));
        }
        let bits = |v: &[f64]| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&x.values), bits(&y.values));
    }
}

fuzz_target!(|data: &[u8]| {
    let opts = ReadOptions::default();
    let Ok(rec) = parse_record(data, Path::new("fuzz.dat"), &opts) else {
        return;
    };
    common::check_clean(&rec);
    for enc in [Uff58Encoding::Binary, Uff58Encoding::AsciiFullPrecision] {
        match Uff58(enc).encode(&rec) {
            Ok(bytes) => {
                let back = parse_record(&bytes, Path::new("back.uff"), &opts)
                    .unwrap_or_else(|e| panic!("own UFF output refused: {e}"));
                same(&rec, &back, true, true);
            }
            Err(RecordError::InvalidRecord { .. }) => {}
            Err(e) => panic!("{e}"),
        }
    }
    match Csv.encode(&rec) {
        Ok(bytes) => {
            let back = parse_record(&bytes, Path::new("back.csv"), &opts).unwrap_or_else(|e| {
                panic!(
                    "own CSV output refused: {e}\n{}",
                    String::from_utf8_lossy(&bytes)
                )
            });
            same(&rec, &back, false, false);
        }
        Err(RecordError::InvalidRecord { .. }) => {}
        Err(e) => panic!("{e}"),
    }
});
