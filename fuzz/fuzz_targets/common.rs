// Shared by the fuzz targets: what an accepted record must satisfy.

use records::RecordFile;

pub fn check_clean(rec: &RecordFile) {
    assert!(rec.dt_s.is_finite() && rec.dt_s > 0.0);
    assert!(rec.start_s.is_finite());
    assert!(!rec.channels.is_empty());
    let n = rec.len();
    assert!(n > 0);
    for c in &rec.channels {
        assert_eq!(c.values.len(), n);
        assert!(c.values.iter().all(|v| v.is_finite()));
    }
}
