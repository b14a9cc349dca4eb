//! Checks that make a report drawable: every per-noise-level vector has one
//! entry per noise level, every FRF series one value per frequency. Anything
//! else (NaN, infinities, empty vectors, odd values) is drawn as well as it
//! can be and noted.

use crate::ReportError;
use crate::model::{Report, Study};

fn mismatch(location: String, what: &str, got: usize, want: usize, per: &str) -> ReportError {
    ReportError::Inconsistent {
        location,
        detail: format!("{what} has {got} value(s) but there are {want} {per}"),
    }
}

pub fn validate(report: &Report) -> Result<(), ReportError> {
    for (i, study) in report.studies.iter().enumerate() {
        validate_study(i + 1, study)?;
    }
    Ok(())
}

fn validate_study(i: usize, study: &Study) -> Result<(), ReportError> {
    let here = format!("study {i} ({:?})", study.name);
    for (j, p) in study.accuracy.panels.iter().enumerate() {
        let at = match &p.axis_value {
            Some(v) => format!("{here}, panel {} ({v:?})", j + 1),
            None => format!("{here}, panel {}", j + 1),
        };
        let n = p.noise_levels.len();
        let levels = "noise levels";
        // Per-level vectors may be left empty when not computed.
        if !p.trials.is_empty() && p.trials.len() != n {
            return Err(mismatch(at, "trials", p.trials.len(), n, levels));
        }
        if !p.failure_rate.is_empty() && p.failure_rate.len() != n {
            return Err(mismatch(
                at,
                "failure_rate",
                p.failure_rate.len(),
                n,
                levels,
            ));
        }
        for q in &p.quantities {
            let at = format!("{at}, quantity {:?}", q.key);
            for (what, v) in [("median", &q.median), ("p5", &q.p5), ("p95", &q.p95)] {
                if !v.is_empty() && v.len() != n {
                    return Err(mismatch(at, what, v.len(), n, levels));
                }
            }
            if let Some(b) = &q.bound
                && !b.is_empty()
                && b.len() != n
            {
                return Err(mismatch(at, "bound", b.len(), n, levels));
            }
        }
    }
    if let Some(rep) = &study.representative {
        for (j, f) in rep.frf.iter().enumerate() {
            let at = format!(
                "{here}, representative campaign, FRF {} ({:?})",
                j + 1,
                f.output
            );
            let n = f.frequency_hz.len();
            let series = [
                ("measured", Some(&f.measured)),
                ("identified", Some(&f.identified)),
                ("truth", f.truth.as_ref()),
            ];
            for (what, v) in series {
                if let Some(v) = v
                    && !v.is_empty()
                    && v.len() != n
                {
                    return Err(mismatch(at, what, v.len(), n, "frequencies"));
                }
            }
        }
    }
    Ok(())
}
