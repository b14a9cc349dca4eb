//! The page of one campaign identified without a known truth
//! ([`CampaignReport`]): what `frameid identify --report` writes for rig
//! records and for FRFs exported by an analyzer.
//!
//! Structure (stable hooks): `section.source`, `section.warnings` (when
//! there are any), `section.hit-quality` (time records), `section.modes`
//! with `table.modes` (`tr[data-in-model=true|false]`), `section.values`
//! with one `table.values[data-table]` per [`ValueTable`], and
//! `section.frf` with per pair `frf-magnitude`, `frf-phase` and, when the
//! coherence is known, `frf-coherence` charts (`data-output` = 1-based
//! pair). The stabilization diagram is `figure[data-chart=stabilization]`.

use std::collections::BTreeSet;
use std::fmt::Write as _;

use crate::ReportError;
use crate::figures;
use crate::format::{MISSING, escape, sig, slug};
use crate::html::{figure, foot, head, hit_quality, row_open};
use crate::model::{CampaignReport, ModeShape, ValueTable};

macro_rules! w {
    ($dst:expr, $($arg:tt)*) => {
        let _ = write!($dst, $($arg)*);
    };
}

/// Checks that every FRF series has one value per frequency line.
fn validate(report: &CampaignReport) -> Result<(), ReportError> {
    for (j, f) in report.frf.iter().enumerate() {
        let n = f.frequency_hz.len();
        let series = [
            ("measured", f.measured.len()),
            ("identified", f.identified.len()),
            ("coherence", f.coherence.as_ref().map_or(0, Vec::len)),
        ];
        for (what, len) in series {
            if len != 0 && len != n {
                return Err(ReportError::Inconsistent {
                    location: format!("campaign report, FRF {} ({:?})", j + 1, f.output),
                    detail: format!("{what} has {len} value(s) but there are {n} frequencies"),
                });
            }
        }
    }
    Ok(())
}

/// Renders the page.
pub fn render(report: &CampaignReport) -> Result<String, ReportError> {
    validate(report)?;
    let mut out = String::with_capacity(256 * 1024);
    let title = if report.title.trim().is_empty() {
        "frameid identification".to_string()
    } else {
        report.title.clone()
    };
    head(&mut out, &report.frameid_version, &title);
    w!(
        out,
        "<header class=\"report-header\">\n<h1>{}</h1>\n<p class=\"meta\">frameid {} · <code class=\"command\">{}</code></p>\n<p class=\"meta\">Identification of mass, stiffness and damping matrices from measured records: no truth is known, so the identified model is checked against the measurements themselves (FRFs and coherence) and its error bars.</p>\n</header>\n<main>\n",
        escape(&title),
        escape(&report.frameid_version),
        escape(&report.command)
    );
    source(&mut out, report);
    if !report.warnings.is_empty() {
        out.push_str(
            "<section class=\"warnings\" id=\"warnings\">\n<h2>Warnings</h2>\n<ul class=\"warnings\">\n",
        );
        for msg in &report.warnings {
            w!(out, "<li>{}</li>\n", escape(msg));
        }
        out.push_str("</ul>\n</section>\n");
    }
    if !report.hit_quality.is_empty() {
        out.push_str("<section class=\"hit-quality\" id=\"hit-quality\">\n<h2>Hits</h2>\n");
        hit_quality(&mut out, &report.hit_quality);
        out.push_str("</section>\n");
    }
    modes(&mut out, report)?;
    values(&mut out, &report.tables);
    frf(&mut out, report)?;
    foot(&mut out, &report.frameid_version);
    Ok(out)
}

fn source(out: &mut String, report: &CampaignReport) {
    out.push_str("<section class=\"source\" id=\"source\">\n<h2>Data and preprocessing</h2>\n<div class=\"table-wrap\"><table class=\"setup\">\n<tbody>\n");
    if report.source.is_empty() {
        out.push_str("<tr><td colspan=\"2\" class=\"missing\">No source rows given.</td></tr>\n");
    }
    for row in &report.source {
        w!(
            out,
            "<tr><th scope=\"row\">{}</th><td>{}</td></tr>\n",
            escape(&row.label),
            escape(&row.value)
        );
    }
    w!(
        out,
        "<tr><th scope=\"row\">frameid version</th><td>{}</td></tr>\n<tr><th scope=\"row\">Command</th><td><code class=\"command\">{}</code></td></tr>\n</tbody>\n</table></div>\n</section>\n",
        escape(&report.frameid_version),
        escape(&report.command)
    );
}

fn mode_rows(out: &mut String, modes: &[ModeShape], in_model: bool, label: &str) {
    for (k, m) in modes.iter().enumerate() {
        let shape = m
            .shape
            .iter()
            .map(|c| {
                let mag = c[0].hypot(c[1]);
                let ph = c[1].atan2(c[0]).to_degrees();
                format!("{}∠{}°", sig(mag, 3), sig(ph, 3))
            })
            .collect::<Vec<_>>()
            .join(", ");
        w!(
            out,
            "<tr data-in-model=\"{in_model}\"><th scope=\"row\">{label}{}</th><td class=\"num\">{}</td><td class=\"num\">{}</td><td>{}</td></tr>\n",
            k + 1,
            sig(m.frequency_hz, 5),
            sig(100.0 * m.damping_ratio, 3),
            shape
        );
    }
}

fn modes(out: &mut String, report: &CampaignReport) -> Result<(), ReportError> {
    w!(
        out,
        "<section class=\"modes\" id=\"modes\">\n<h2>Modes</h2>\n<p class=\"lede\">{} mode(s) form the model; {} structural mode(s) were identified outside it (modes a shear frame of this many floors does not have: torsion, out-of-plane or local modes).</p>\n",
        report.modes.len(),
        report.out_of_model.len()
    );
    out.push_str("<div class=\"table-wrap\"><table class=\"modes\">\n<caption>Identified modes (shapes: magnitude∠phase per response, largest component 1)</caption>\n<thead><tr><th scope=\"col\">Mode</th><th scope=\"col\" class=\"num\">Frequency [Hz]</th><th scope=\"col\" class=\"num\">Damping [%]</th><th scope=\"col\">Shape</th></tr></thead>\n<tbody>\n");
    if report.modes.is_empty() && report.out_of_model.is_empty() {
        out.push_str("<tr><td colspan=\"4\" class=\"missing\">No modes.</td></tr>\n");
    }
    mode_rows(out, &report.modes, true, "");
    mode_rows(out, &report.out_of_model, false, "x");
    out.push_str("</tbody>\n</table></div>\n");
    if !report.stabilization.is_empty() {
        figure(
            out,
            &figures::stabilization_of(
                "campaign",
                &report.stabilization,
                &report.modes,
                &report.out_of_model,
                report.order,
            ),
            "wide",
        )?;
    }
    for (mag, phase) in &figures::modes_of("campaign", &report.modes) {
        row_open(out, 2, "mode");
        figure(out, mag, "")?;
        figure(out, phase, "")?;
        out.push_str("</div>\n");
    }
    out.push_str("</section>\n");
    Ok(())
}

fn values(out: &mut String, tables: &[ValueTable]) {
    out.push_str("<section class=\"values\" id=\"values\">\n<h2>Identified values</h2>\n");
    if tables.is_empty() {
        out.push_str("<p class=\"missing\">No values.</p>\n");
    }
    out.push_str("<div class=\"tables\">\n");
    let mut used = BTreeSet::new();
    for t in tables {
        let mut key = slug(&t.title);
        let base = key.clone();
        let mut n = 2;
        while !used.insert(key.clone()) {
            key = format!("{base}-{n}");
            n += 1;
        }
        let unit = if t.unit.trim().is_empty() {
            String::new()
        } else {
            format!(" [{}]", escape(&t.unit))
        };
        w!(
            out,
            "<div class=\"table-wrap\"><table class=\"values\" data-table=\"{key}\">\n<caption>{}{}</caption>\n<thead><tr><th scope=\"col\">Entry</th><th scope=\"col\" class=\"num\">Identified</th><th scope=\"col\" class=\"num\">± std</th><th scope=\"col\" class=\"num\">Relative std</th></tr></thead>\n<tbody>\n",
            escape(&t.title),
            unit
        );
        for r in &t.rows {
            let (std, rel) = match r.std {
                Some(s) if r.value != 0.0 && r.value.is_finite() => (
                    format!("± {}", sig(s, 2)),
                    format!("{} %", sig(100.0 * s / r.value.abs(), 2)),
                ),
                Some(s) => (format!("± {}", sig(s, 2)), MISSING.to_string()),
                None => (MISSING.to_string(), MISSING.to_string()),
            };
            w!(
                out,
                "<tr><th scope=\"row\">{}</th><td class=\"num\" data-value=\"{:e}\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td></tr>\n",
                escape(&r.label),
                r.value,
                sig(r.value, 5),
                std,
                rel
            );
        }
        out.push_str("</tbody>\n</table></div>\n");
    }
    out.push_str("</div>\n</section>\n");
}

fn frf(out: &mut String, report: &CampaignReport) -> Result<(), ReportError> {
    out.push_str(
        "<section class=\"frf\" id=\"frf\">\n<h2>Measured FRFs against the identified model</h2>\n",
    );
    if report.frf.is_empty() {
        out.push_str("<p class=\"missing\">No frequency responses given.</p>\n");
    }
    let pairs = figures::frf("campaign", 1, &report.frf);
    for (j, ((mag, phase), f)) in pairs.iter().zip(&report.frf).enumerate() {
        let coherence = figures::coherence("campaign", j + 1, f);
        row_open(out, if coherence.is_some() { 3 } else { 2 }, "frf");
        figure(out, mag, "")?;
        figure(out, phase, "")?;
        if let Some(c) = &coherence {
            figure(out, c, "")?;
        }
        out.push_str("</div>\n");
    }
    out.push_str("</section>\n");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Frf, SetupRow, ValueRow};

    fn page() -> CampaignReport {
        let frequency_hz = vec![1.0, 2.0, 3.0];
        CampaignReport {
            title: String::new(),
            frameid_version: "0".into(),
            command: "frameid identify a.uff".into(),
            source: vec![SetupRow {
                label: "Files".into(),
                value: "a.uff".into(),
            }],
            warnings: vec!["a <warning>".into()],
            hit_quality: Vec::new(),
            order: 4,
            stabilization: Vec::new(),
            modes: Vec::new(),
            out_of_model: Vec::new(),
            frf: vec![Frf {
                output: "acc1".into(),
                frequency_hz,
                measured: vec![[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]],
                identified: Vec::new(),
                truth: None,
                reference: Some("force".into()),
                coherence: Some(vec![0.9, 0.99, 0.5]),
            }],
            tables: vec![ValueTable {
                title: "Mass matrix M".into(),
                unit: "kg".into(),
                rows: vec![ValueRow {
                    label: "M11".into(),
                    value: 2.5,
                    std: Some(0.025),
                }],
            }],
        }
    }

    #[test]
    fn renders_deterministically_escaped_and_with_relative_errors() {
        let html = render(&page()).unwrap();
        assert_eq!(render(&page()).unwrap(), html);
        assert!(html.contains("a &lt;warning&gt;"));
        assert!(html.contains("<title>frameid identification</title>"));
        assert!(html.contains("id=\"campaign-frf-1-coherence\""));
        // 0.025 / 2.5 = 1 %.
        assert!(html.contains("<td class=\"num\">1.0 %</td>"), "{html}");
    }

    #[test]
    fn a_coherence_of_the_wrong_length_is_refused() {
        let mut p = page();
        p.frf[0].coherence = Some(vec![1.0]);
        let e = render(&p).unwrap_err();
        assert!(e.to_string().contains("coherence has 1 value(s)"), "{e}");
    }
}
