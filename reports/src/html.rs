//! The HTML document: one file, inline CSS and SVG, no script, nothing
//! fetched. The structure is described in the crate documentation.

use std::collections::BTreeSet;
use std::fmt::Write as _;

use crate::ReportError;
use crate::chart::{self, Axis};
use crate::figures::{self, Fig, PanelView, level_label};
use crate::format::{MISSING, escape, noise_percent, percent, relative_error, sig, slug};
use crate::model::{Accuracy, ComparisonTable, Panel, Quantity, Report, Representative, Study};

macro_rules! w {
    ($dst:expr, $($arg:tt)*) => {
        let _ = write!($dst, $($arg)*);
    };
}

/// The style sheet. The identified-against-truth tables (`.tables`) flow in
/// a wrapping row, each as wide as its columns need, rather than in grid
/// tracks of a fixed minimum width: tracks narrower than a table hid its
/// relative errors behind a scrollbar (see the test
/// `comparison_tables_take_the_width_their_columns_need`). A table wider
/// than the page column shrinks to it and scrolls; on narrow screens the
/// cells get less padding and the headers may wrap.
pub(crate) const CSS: &str = r#"
:root { --fg: #1b1b1b; --muted: #555; --rule: #cfcfcf; --accent: #0072b2; --warn: #d55e00; }
* { box-sizing: border-box; }
html { background: #fff; }
body { margin: 0 auto; max-width: 1180px; padding: 1.2rem 1.5rem 3rem; color: var(--fg); background: #fff;
  font: 15px/1.45 system-ui, -apple-system, "Segoe UI", Roboto, "Helvetica Neue", Arial, sans-serif; }
h1 { font-size: 1.6rem; margin: .2rem 0 .3rem; }
h2 { font-size: 1.35rem; margin: 2.2rem 0 .4rem; padding-bottom: .2rem; border-bottom: 2px solid var(--accent); }
h3 { font-size: 1.12rem; margin: 1.6rem 0 .4rem; }
h4 { font-size: 1rem; margin: 1.2rem 0 .3rem; color: #333; }
p { margin: .3rem 0 .6rem; }
code { font-family: ui-monospace, "SFMono-Regular", Menlo, Consolas, monospace; font-size: .88em; overflow-wrap: anywhere; }
.meta, .lede { color: var(--muted); }
nav.toc ol { margin: .3rem 0; padding-left: 1.4rem; }
nav.toc a { color: var(--accent); text-decoration: none; }
.table-wrap { overflow-x: auto; margin: .4rem 0 1rem; }
table { border-collapse: collapse; font-size: .88rem; }
caption { text-align: left; font-weight: 600; padding: .2rem 0; }
th, td { border-bottom: 1px solid var(--rule); padding: .18rem .55rem; text-align: left; vertical-align: top; }
thead th { border-bottom: 1.5px solid #888; }
th[scope=row] { font-weight: 600; }
td.num, th.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
td.bad { color: var(--warn); font-weight: 600; }
table.setup td { overflow-wrap: anywhere; }
.figure-row { display: grid; grid-template-columns: repeat(var(--cols, 2), minmax(0, 1fr)); gap: .6rem 1rem; margin: .4rem 0 .8rem; }
figure.chart { margin: 0 0 .8rem; }
figure.chart.wide { max-width: 900px; }
figure.chart.medium { max-width: 720px; }
.tables { display: flex; flex-wrap: wrap; align-items: flex-start; gap: 0 1.5rem; }
.tables > .table-wrap { flex: 0 1 auto; min-width: 0; max-width: 100%; }
table.comparison th, table.comparison td { padding-left: .45rem; padding-right: .45rem; }
@media (max-width: 600px) {
  table.comparison th, table.comparison td { padding-left: .3rem; padding-right: .3rem; }
  table.comparison thead th { white-space: normal; }
}
figure.chart svg { display: block; width: 100%; height: auto; }
figcaption { font-size: .8rem; color: var(--muted); margin-top: .15rem; }
.placeholder { border: 1px dashed var(--rule); color: var(--muted); padding: 1rem; font-size: .85rem; align-self: center; }
.warnings { border-left: 4px solid var(--warn); padding: .3rem .8rem .3rem 1.6rem; margin: .5rem 0; }
.missing { color: var(--muted); font-style: italic; }
.quantity-group > h4::first-letter { text-transform: uppercase; }
footer { margin-top: 3rem; color: var(--muted); font-size: .8rem; }
@media print {
  body { max-width: none; padding: 0; font-size: 9.5pt; }
  a { color: inherit; text-decoration: none; }
  article.study + article.study { break-before: page; }
  h2, h3, h4 { break-after: avoid; page-break-after: avoid; }
  figure.chart, .figure-row, table, tr, .efficiency, .routes, .damping-comparison { break-inside: avoid; page-break-inside: avoid; }
  .table-wrap { overflow: visible; }
  table { font-size: 8pt; }
  th, td { padding: .1rem .35rem; }
  td.num { white-space: normal; }
  .figure-row { gap: .3rem .6rem; }
}
@page { margin: 14mm 12mm; }
"#;

/// The document up to `<body>`: charset, viewport, generator, title and
/// the inline style sheet.
pub(crate) fn head(out: &mut String, version: &str, title: &str) {
    w!(
        out,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n<meta name=\"generator\" content=\"frameid {}\">\n<title>{}</title>\n<style>{}</style>\n</head>\n<body>\n",
        escape(version),
        escape(title),
        CSS
    );
}

/// The end of `<main>`, the footer and the end of the document.
pub(crate) fn foot(out: &mut String, version: &str) {
    w!(
        out,
        "</main>\n<footer>Generated by frameid {}. Self-contained: all charts are inline SVG; nothing is loaded from elsewhere.</footer>\n</body>\n</html>\n",
        escape(version)
    );
}

/// Renders the whole document.
pub fn render(report: &Report) -> Result<String, ReportError> {
    let mut out = String::with_capacity(512 * 1024);
    let title = if report.title.trim().is_empty() {
        "frameid report".to_string()
    } else {
        report.title.clone()
    };
    head(&mut out, &report.frameid_version, &title);
    w!(
        out,
        "<header class=\"report-header\">\n<h1>{}</h1>\n<p class=\"meta\">frameid {} · <code class=\"command\">{}</code></p>\n<p class=\"meta\">Identification of mass, stiffness and damping matrices from impact-hammer tests: OKID, ERA/DC, modal parameters, Rayleigh fit and MKR (Guida, Nilvetti, Pappalardo, COMPDYN 2011). Noise levels are given as a percentage of each channel's RMS.</p>\n</header>\n",
        escape(&title),
        escape(&report.frameid_version),
        escape(&report.command)
    );
    toc(&mut out, report);
    out.push_str("<main>\n");
    if report.studies.is_empty() {
        out.push_str("<p class=\"missing\">This report contains no study.</p>\n");
    }
    for (i, study) in report.studies.iter().enumerate() {
        study_html(&mut out, i + 1, study, report)?;
    }
    foot(&mut out, &report.frameid_version);
    Ok(out)
}

fn toc(out: &mut String, report: &Report) {
    if report.studies.is_empty() {
        return;
    }
    out.push_str("<nav class=\"toc\">\n<h2>Contents</h2>\n<ol>\n");
    for (i, s) in report.studies.iter().enumerate() {
        let i = i + 1;
        w!(
            out,
            "<li><a href=\"#study-{i}\">{}</a> — <a href=\"#study-{i}-setup\">set-up</a>, <a href=\"#study-{i}-representative\">representative campaign</a>, <a href=\"#study-{i}-comparison\">identified against truth</a>, <a href=\"#study-{i}-accuracy\">accuracy against noise</a></li>\n",
            escape(&s.name)
        );
    }
    out.push_str("</ol>\n</nav>\n");
}

fn study_html(
    out: &mut String,
    i: usize,
    study: &Study,
    report: &Report,
) -> Result<(), ReportError> {
    let sid = format!("study-{i}");
    w!(
        out,
        "<article class=\"study\" id=\"{sid}\" data-study=\"{}\">\n<h2>Study {i}: {}</h2>\n",
        escape(&study.name),
        escape(&study.name)
    );
    if !study.description.trim().is_empty() {
        w!(
            out,
            "<p class=\"description\">{}</p>\n",
            escape(&study.description)
        );
    }
    setup(out, &sid, study, report);
    representative(out, &sid, study.representative.as_ref())?;
    comparison(out, &sid, study.representative.as_ref());
    accuracy(out, &sid, &study.accuracy)?;
    out.push_str("</article>\n");
    Ok(())
}

fn setup(out: &mut String, sid: &str, study: &Study, report: &Report) {
    w!(
        out,
        "<section class=\"setup\" id=\"{sid}-setup\">\n<h3>Set-up</h3>\n<div class=\"table-wrap\"><table class=\"setup\">\n<tbody class=\"setup-rows\">\n"
    );
    if study.setup.is_empty() {
        out.push_str("<tr><td colspan=\"2\" class=\"missing\">No set-up rows given.</td></tr>\n");
    }
    for row in &study.setup {
        w!(
            out,
            "<tr><th scope=\"row\">{}</th><td>{}</td></tr>\n",
            escape(&row.label),
            escape(&row.value)
        );
    }
    w!(
        out,
        "</tbody>\n<tbody class=\"provenance\">\n<tr><th scope=\"row\">frameid version</th><td>{}</td></tr>\n<tr><th scope=\"row\">Seed</th><td class=\"seed\">{}</td></tr>\n<tr><th scope=\"row\">Command</th><td><code class=\"command\">{}</code></td></tr>\n</tbody>\n</table></div>\n</section>\n",
        escape(&report.frameid_version),
        study.seed,
        escape(&report.command)
    );
}

/// Draws a figure into the page.
pub(crate) fn figure(out: &mut String, fig: &Fig, class: &str) -> Result<(), ReportError> {
    let drawn = chart::draw(&fig.chart)?;
    w!(
        out,
        "<figure class=\"chart{}{}\" id=\"{}\" data-chart=\"{}\"{}>\n{}",
        if class.is_empty() { "" } else { " " },
        class,
        escape(&fig.chart.id),
        escape(&fig.chart.kind),
        fig.attrs,
        drawn.svg,
    );
    if !fig.caption.is_empty() || !drawn.notes.is_empty() {
        out.push_str("<figcaption>");
        out.push_str(&fig.caption);
        for note in &drawn.notes {
            w!(out, " <span class=\"note\">{}</span>", escape(note));
        }
        out.push_str("</figcaption>");
    }
    out.push_str("</figure>\n");
    Ok(())
}

pub(crate) fn row_open(out: &mut String, cols: usize, class: &str) {
    w!(
        out,
        "<div class=\"figure-row{}{}\" style=\"--cols: {}\">\n",
        if class.is_empty() { "" } else { " " },
        class,
        cols.max(1)
    );
}

fn representative(
    out: &mut String,
    sid: &str,
    rep: Option<&Representative>,
) -> Result<(), ReportError> {
    w!(
        out,
        "<section class=\"representative\" id=\"{sid}-representative\">\n<h3>One representative campaign</h3>\n"
    );
    let Some(rep) = rep else {
        out.push_str("<p class=\"missing\">No representative campaign was recorded for this study.</p>\n</section>\n");
        return Ok(());
    };
    let fs = if rep.dt_s.is_finite() && rep.dt_s > 0.0 {
        format!(" ({} Hz)", sig(1.0 / rep.dt_s, 4))
    } else {
        String::new()
    };
    w!(
        out,
        "<p class=\"lede\">Noise level {} % of the channel RMS · sampling interval {} s{} · hammer on floor {} · state order n = {} · {} mode(s) identified.</p>\n",
        noise_percent(rep.noise_fraction),
        sig(rep.dt_s, 5),
        fs,
        rep.hit_floor,
        rep.order,
        rep.modes.len()
    );
    if !rep.warnings.is_empty() {
        out.push_str("<ul class=\"warnings\">\n");
        for wmsg in &rep.warnings {
            w!(out, "<li>{}</li>\n", escape(wmsg));
        }
        out.push_str("</ul>\n");
    }
    hit_quality(out, &rep.hit_quality);

    out.push_str("<h4>Records of the first hit</h4>\n");
    figure(out, &figures::force(sid, rep), "wide")?;
    if rep.accelerations.is_empty() {
        out.push_str("<p class=\"missing\">No acceleration records given.</p>\n");
    }
    for fig in figures::accelerations(sid, rep) {
        figure(out, &fig, "wide")?;
    }

    out.push_str("<h4>Model order</h4>\n");
    figure(out, &figures::hankel(sid, rep), "medium")?;
    figure(out, &figures::stabilization(sid, rep), "wide")?;

    out.push_str("<h4>Mode shapes</h4>\n");
    let modes = figures::modes(sid, rep);
    if modes.is_empty() {
        out.push_str("<p class=\"missing\">No modes identified.</p>\n");
    }
    for (mag, phase) in &modes {
        row_open(out, 2, "mode");
        figure(out, mag, "")?;
        figure(out, phase, "")?;
        out.push_str("</div>\n");
    }

    out.push_str("<h4>Frequency response</h4>\n");
    let frfs = figures::frf(sid, rep.hit_floor, &rep.frf);
    if frfs.is_empty() {
        out.push_str("<p class=\"missing\">No frequency responses given.</p>\n");
    }
    for (mag, phase) in &frfs {
        row_open(out, 2, "frf");
        figure(out, mag, "")?;
        figure(out, phase, "")?;
        out.push_str("</div>\n");
    }
    out.push_str("</section>\n");
    Ok(())
}

/// The per-hit quality table: peak force, pulse duration, worst SNR, tail
/// ratio and the failed checks.
pub(crate) fn hit_quality(out: &mut String, rows: &[crate::model::HitQualityRow]) {
    if rows.is_empty() {
        return;
    }
    out.push_str("<div class=\"table-wrap\"><table class=\"hit-quality\">\n<caption>Hit quality (checked before identification)</caption>\n<thead><tr><th scope=\"col\">Hit</th><th scope=\"col\" class=\"num\">Peak force [N]</th><th scope=\"col\" class=\"num\">Pulse [ms]</th><th scope=\"col\" class=\"num\">Lowest SNR [dB]</th><th scope=\"col\" class=\"num\">End / peak</th><th scope=\"col\">Checks</th></tr></thead>\n<tbody>\n");
    for r in rows {
        let checks = if r.flags.is_empty() {
            "passed".to_string()
        } else {
            r.flags
                .iter()
                .map(|f| escape(f))
                .collect::<Vec<_>>()
                .join("; ")
        };
        w!(
            out,
            "<tr{}><th scope=\"row\">{}</th><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td>{}</td></tr>\n",
            if r.flags.is_empty() {
                ""
            } else {
                " class=\"bad\""
            },
            r.hit,
            sig(r.peak_force_n, 4),
            sig(1e3 * r.pulse_duration_s, 3),
            sig(r.min_snr_db, 3),
            sig(r.tail_ratio, 2),
            checks
        );
    }
    out.push_str("</tbody>\n</table></div>\n");
}

fn comparison(out: &mut String, sid: &str, rep: Option<&Representative>) {
    w!(
        out,
        "<section class=\"comparison\" id=\"{sid}-comparison\">\n<h3>Identified against truth</h3>\n"
    );
    let tables = rep.map(|r| r.tables.as_slice()).unwrap_or(&[]);
    if tables.is_empty() {
        out.push_str(
            "<p class=\"missing\">No comparison with the truth is available.</p>\n</section>\n",
        );
        return;
    }
    out.push_str("<p class=\"lede\">Relative error = (identified − truth) / |truth|, for the representative campaign above.</p>\n");
    let mut used = BTreeSet::new();
    out.push_str("<div class=\"tables\">\n");
    for t in tables {
        comparison_table(out, t, &mut used);
    }
    out.push_str("</div>\n</section>\n");
}

fn comparison_table(out: &mut String, t: &ComparisonTable, used: &mut BTreeSet<String>) {
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
    let with_std = t.rows.iter().any(|r| r.std.is_some());
    w!(
        out,
        "<div class=\"table-wrap\"><table class=\"comparison\" data-table=\"{key}\">\n<caption>{}{}</caption>\n<thead><tr><th scope=\"col\">Entry</th><th scope=\"col\" class=\"num\">Truth</th><th scope=\"col\" class=\"num\">Identified</th>{}<th scope=\"col\" class=\"num\">Relative error</th></tr></thead>\n<tbody>\n",
        escape(&t.title),
        unit,
        if with_std {
            "<th scope=\"col\" class=\"num\">± std</th>"
        } else {
            ""
        }
    );
    if t.rows.is_empty() {
        out.push_str("<tr><td colspan=\"4\" class=\"missing\">No rows.</td></tr>\n");
    }
    for r in &t.rows {
        let rel = relative_error(r.truth, r.identified);
        let (text, data, class) = match rel {
            Some(e) => (
                percent(e),
                format!("{e:e}"),
                if e.abs() > 0.1 { "num bad" } else { "num" },
            ),
            None if r.truth == 0.0 && r.identified.is_finite() => {
                (format!("{MISSING} (truth 0)"), "none".to_string(), "num")
            }
            None => (MISSING.to_string(), "none".to_string(), "num"),
        };
        let std_cell = if with_std {
            format!(
                "<td class=\"num\" data-std=\"{}\">{}</td>",
                r.std.map_or("none".to_string(), |v| format!("{v:e}")),
                r.std
                    .map_or(MISSING.to_string(), |v| format!("± {}", sig(v, 2)))
            )
        } else {
            String::new()
        };
        w!(
            out,
            "<tr><th scope=\"row\">{}</th><td class=\"num\">{}</td><td class=\"num\">{}</td>{std_cell}<td class=\"{class}\" data-rel-error=\"{data}\">{}</td></tr>\n",
            escape(&r.label),
            sig(r.truth, 5),
            sig(r.identified, 5),
            escape(&text)
        );
    }
    out.push_str("</tbody>\n</table></div>\n");
}

/// Quantity keys in order of first appearance, grouped by `group` (groups
/// in order of first appearance).
fn grouped_keys(acc: &Accuracy) -> Vec<(String, Vec<String>)> {
    let mut groups: Vec<(String, Vec<String>)> = vec![];
    for p in &acc.panels {
        for q in &p.quantities {
            if groups.iter().any(|(_, keys)| keys.contains(&q.key)) {
                continue;
            }
            match groups.iter_mut().find(|(g, _)| *g == q.group) {
                Some((_, keys)) => keys.push(q.key.clone()),
                None => groups.push((q.group.clone(), vec![q.key.clone()])),
            }
        }
    }
    groups
}

fn find<'a>(p: &'a Panel, key: &str) -> Option<&'a Quantity> {
    p.quantities.iter().find(|q| q.key == key)
}

const MKR: &str = "damping_mkr_err";
const RAYLEIGH: &str = "damping_rayleigh_err";
const REFINED: &str = "damping_refined_err";

fn accuracy(out: &mut String, sid: &str, acc: &Accuracy) -> Result<(), ReportError> {
    w!(
        out,
        "<section class=\"accuracy\" id=\"{sid}-accuracy\">\n<h3>Accuracy against noise</h3>\n"
    );
    if acc.panels.is_empty() {
        out.push_str("<p class=\"missing\">No Monte Carlo results in this study.</p>\n");
        efficiency(out, acc);
        routes(out, acc);
        out.push_str("</section>\n");
        return Ok(());
    }
    let levels: Vec<f64> = acc
        .panels
        .iter()
        .flat_map(|p| p.noise_levels.iter().copied())
        .collect();
    let x = Axis::noise(&levels);
    let k = acc.panels.len();
    let axis_name = acc.axis_name.as_deref();
    let size = if k <= 2 { (440, 300) } else { (400, 300) };
    let log_x = x.label.contains("log");

    // "200 trials per level", or per panel when they differ.
    let per_panel: Vec<String> = acc
        .panels
        .iter()
        .map(|p| {
            let t: BTreeSet<usize> = p.trials.iter().copied().collect();
            let t: Vec<String> = t.iter().map(|n| n.to_string()).collect();
            if t.is_empty() {
                MISSING.to_string()
            } else {
                t.join("/")
            }
        })
        .collect();
    let trials = if per_panel.iter().all(|t| *t == per_panel[0]) {
        per_panel[0].clone()
    } else {
        acc.panels
            .iter()
            .zip(&per_panel)
            .map(|(p, t)| match &p.axis_value {
                Some(v) => format!("{t} for {v}"),
                None => t.clone(),
            })
            .collect::<Vec<_>>()
            .join(", ")
    };
    w!(
        out,
        "<p class=\"lede\">Monte Carlo sweep over {} noise level(s) ({} trials per level). Lines: medians over successful trials; bands: 5th to 95th percentile; dashed lines: Cramér–Rao bound (standard deviation) where known.{}{}</p>\n",
        acc.panels[0].noise_levels.len(),
        escape(&trials),
        if log_x {
            " Noise levels are on a log scale; 0 % is drawn left of the smallest positive level."
        } else {
            ""
        },
        match axis_name {
            Some(name) if k > 1 => format!(
                " One panel per value of {}, side by side on the same axes.",
                escape(name)
            ),
            _ => String::new(),
        }
    );

    let combine = acc
        .panels
        .iter()
        .any(|p| find(p, MKR).is_some() && find(p, RAYLEIGH).is_some());
    let mut used_ids = BTreeSet::new();
    let mut unique = |id: String| -> String {
        let mut candidate = id.clone();
        let mut n = 2;
        while !used_ids.insert(candidate.clone()) {
            candidate = format!("{id}-{n}");
            n += 1;
        }
        candidate
    };

    for (gi, (group, keys)) in grouped_keys(acc).iter().enumerate() {
        let has_pair = combine && keys.iter().any(|k| k == MKR || k == RAYLEIGH);
        let keys: Vec<&String> = keys
            .iter()
            .filter(|k| !(combine && (*k == MKR || *k == RAYLEIGH || *k == REFINED)))
            .collect();
        let title = if group.trim().is_empty() {
            "other"
        } else {
            group.as_str()
        };
        w!(
            out,
            "<div class=\"quantity-group\" data-group=\"{}\">\n<h4>{}</h4>\n",
            escape(group),
            escape(title)
        );
        if k == 1 && !keys.is_empty() {
            row_open(out, 2, "quantities");
        }
        for (qi, key) in keys.iter().enumerate() {
            let qs: Vec<&Quantity> = acc.panels.iter().filter_map(|p| find(p, key)).collect();
            let Some(first) = qs.first() else { continue };
            let (y, y_note) = figures::quantity_axis(figures::quantity_label(first), &qs);
            if k > 1 {
                row_open(out, k, "panels");
            }
            for (pj, p) in acc.panels.iter().enumerate() {
                match find(p, key) {
                    Some(q) => {
                        let id = unique(format!("{sid}-q{gi}-{qi}-{}-p{}", slug(key), pj + 1));
                        let view = PanelView {
                            panel: p,
                            axis_name,
                            x: &x,
                            y: &y,
                            size,
                        };
                        let mut fig = figures::quantity(id, q, &view);
                        fig.attrs.push_str(&format!(" data-panel=\"{}\"", pj + 1));
                        if let Some(n) = &y_note {
                            fig.caption.push(' ');
                            fig.caption.push_str(&escape(n));
                        }
                        figure(out, &fig, "")?;
                    }
                    None => placeholder(out, &first.label, axis_name, p),
                }
            }
            if k > 1 {
                out.push_str("</div>\n");
            }
        }
        if k == 1 && !keys.is_empty() {
            out.push_str("</div>\n");
        }
        if has_pair {
            damping_pairs(out, sid, acc, &x, size, &mut unique)?;
        }
        out.push_str("</div>\n");
    }

    failures(out, sid, acc, &x, size)?;
    efficiency(out, acc);
    routes(out, acc);
    out.push_str("</section>\n");
    Ok(())
}

fn placeholder(out: &mut String, label: &str, axis_name: Option<&str>, p: &Panel) {
    w!(
        out,
        "<div class=\"placeholder\">{} was not computed{}.</div>\n",
        escape(label),
        match (&p.axis_value, axis_name) {
            (Some(v), Some(n)) => format!(" for {} = {}", escape(n), escape(v)),
            (Some(v), None) => format!(" for {}", escape(v)),
            _ => String::new(),
        }
    );
}

fn damping_pairs(
    out: &mut String,
    sid: &str,
    acc: &Accuracy,
    x: &Axis,
    size: (u32, u32),
    unique: &mut impl FnMut(String) -> String,
) -> Result<(), ReportError> {
    let k = acc.panels.len();
    let qs: Vec<&Quantity> = acc
        .panels
        .iter()
        .flat_map(|p| [find(p, MKR), find(p, RAYLEIGH), find(p, REFINED)])
        .flatten()
        .collect();
    let unit = qs.first().map(|q| q.unit.trim()).unwrap_or("");
    let label = if unit.is_empty() {
        "Damping matrix error".to_string()
    } else {
        format!("Damping matrix error [{unit}]")
    };
    let (y, _) = figures::quantity_axis(label, &qs);
    w!(out, "<div class=\"damping-comparison\">\n");
    // One panel: a larger chart on its own; several: side by side.
    let (size, class) = if k == 1 {
        ((600, 360), "medium")
    } else {
        (size, "")
    };
    if k > 1 {
        row_open(out, k, "panels");
    }
    for (pj, p) in acc.panels.iter().enumerate() {
        match (find(p, MKR), find(p, RAYLEIGH)) {
            (Some(m), Some(r)) => {
                let id = unique(format!("{sid}-damping-p{}", pj + 1));
                let mut fig = figures::damping_pair(
                    id,
                    m,
                    r,
                    find(p, REFINED),
                    &PanelView {
                        panel: p,
                        axis_name: acc.axis_name.as_deref(),
                        x,
                        y: &y,
                        size,
                    },
                );
                fig.attrs.push_str(&format!(" data-panel=\"{}\"", pj + 1));
                figure(out, &fig, class)?;
            }
            _ => placeholder(
                out,
                "The MKR and Rayleigh damping comparison",
                acc.axis_name.as_deref(),
                p,
            ),
        }
    }
    if k > 1 {
        out.push_str("</div>\n");
    }
    out.push_str("</div>\n");
    Ok(())
}

fn failures(
    out: &mut String,
    sid: &str,
    acc: &Accuracy,
    x: &Axis,
    size: (u32, u32),
) -> Result<(), ReportError> {
    let k = acc.panels.len();
    out.push_str("<div class=\"failures\">\n<h4>Failures</h4>\n");
    // One panel: chart and table side by side; several: a row of charts
    // over a row of tables.
    row_open(out, if k == 1 { 2 } else { k }, "panels");
    for (pj, p) in acc.panels.iter().enumerate() {
        let mut fig = figures::failure_rate(
            format!("{sid}-failure-p{}", pj + 1),
            &PanelView {
                panel: p,
                axis_name: acc.axis_name.as_deref(),
                x,
                y: x,
                size,
            },
        );
        fig.attrs = format!(" data-panel=\"{}\"", pj + 1);
        figure(out, &fig, "")?;
    }
    if k > 1 {
        out.push_str("</div>\n");
        row_open(out, k, "panels");
    }
    for (pj, p) in acc.panels.iter().enumerate() {
        failure_table(out, pj + 1, acc.axis_name.as_deref(), p);
    }
    out.push_str("</div>\n</div>\n");
    Ok(())
}

fn same_level(a: f64, b: f64) -> bool {
    a == b || (a - b).abs() <= 1e-9 * a.abs().max(b.abs())
}

fn failure_table(out: &mut String, panel: usize, axis_name: Option<&str>, p: &Panel) {
    let caption = match (&p.axis_value, axis_name) {
        (Some(v), Some(n)) => format!("Failed trials by reason, {} = {}", escape(n), escape(v)),
        (Some(v), None) => format!("Failed trials by reason, {}", escape(v)),
        _ => "Failed trials by reason".to_string(),
    };
    w!(
        out,
        "<div class=\"table-wrap\"><table class=\"failures\" data-panel=\"{panel}\">\n<caption>{caption}</caption>\n<thead><tr><th scope=\"col\">Noise level</th>"
    );
    for &l in &p.noise_levels {
        w!(
            out,
            "<th scope=\"col\" class=\"num\">{}</th>",
            escape(&level_label(l))
        );
    }
    out.push_str("</tr></thead>\n<tbody>\n<tr class=\"trials\"><th scope=\"row\">Trials</th>");
    for i in 0..p.noise_levels.len() {
        match p.trials.get(i) {
            Some(t) => {
                w!(out, "<td class=\"num\">{t}</td>");
            }
            None => {
                w!(out, "<td class=\"num\">{MISSING}</td>");
            }
        }
    }
    out.push_str("</tr>\n<tr class=\"failure-rate\"><th scope=\"row\">Failure rate</th>");
    for i in 0..p.noise_levels.len() {
        let r = p.failure_rate.get(i).copied().unwrap_or(f64::NAN);
        let text = if r.is_finite() {
            format!("{} %", crate::format::trim(r * 100.0, 3))
        } else {
            MISSING.to_string()
        };
        w!(out, "<td class=\"num\">{text}</td>");
    }
    out.push_str("</tr>\n");
    let mut reasons: Vec<&str> = vec![];
    for f in &p.failure_reasons {
        if !reasons.contains(&f.reason.as_str()) {
            reasons.push(&f.reason);
        }
    }
    let mut unmatched = 0usize;
    for f in &p.failure_reasons {
        if !p.noise_levels.iter().any(|&l| same_level(l, f.noise_level)) {
            unmatched += f.count;
        }
    }
    for reason in &reasons {
        w!(
            out,
            "<tr class=\"reason\"><th scope=\"row\">{}</th>",
            escape(reason)
        );
        for &l in &p.noise_levels {
            let n: usize = p
                .failure_reasons
                .iter()
                .filter(|f| f.reason == *reason && same_level(f.noise_level, l))
                .map(|f| f.count)
                .sum();
            w!(out, "<td class=\"num\">{n}</td>");
        }
        out.push_str("</tr>\n");
    }
    if reasons.is_empty() {
        w!(
            out,
            "<tr><td colspan=\"{}\" class=\"missing\">No failures recorded.</td></tr>\n",
            p.noise_levels.len() + 1
        );
    }
    out.push_str("</tbody>\n</table></div>\n");
    if unmatched > 0 {
        w!(
            out,
            "<p class=\"missing\">{unmatched} failure(s) are recorded at noise levels that are not in this panel.</p>\n"
        );
    }
}

fn efficiency(out: &mut String, acc: &Accuracy) {
    if acc.efficiency.is_empty() {
        return;
    }
    let mut levels: Vec<f64> = vec![];
    let mut rows: Vec<(&str, &str)> = vec![];
    for e in &acc.efficiency {
        if !levels.iter().any(|&l| same_level(l, e.noise_level)) {
            levels.push(e.noise_level);
        }
        let key = (e.quantity.as_str(), e.estimator.as_str());
        if !rows.contains(&key) {
            rows.push(key);
        }
    }
    levels.sort_by(f64::total_cmp);
    out.push_str("<div class=\"efficiency\">\n<h4>Efficiency</h4>\n<p class=\"lede\">Cramér–Rao bound (standard deviation) divided by the estimator's RMS error over the trials; 1 means the estimator reaches the bound, a small value that it is far from it (or biased). ± is the Monte Carlo standard error from the trials.</p>\n");
    out.push_str("<div class=\"table-wrap\"><table class=\"efficiency\">\n<thead><tr><th scope=\"col\">Quantity</th><th scope=\"col\">Estimator</th>");
    for &l in &levels {
        w!(
            out,
            "<th scope=\"col\" class=\"num\">{}</th>",
            escape(&level_label(l))
        );
    }
    out.push_str("</tr></thead>\n<tbody>\n");
    for (q, est) in rows {
        w!(
            out,
            "<tr><th scope=\"row\">{}</th><td>{}</td>",
            escape(q),
            escape(est)
        );
        for &l in &levels {
            let v = acc
                .efficiency
                .iter()
                .find(|e| e.quantity == q && e.estimator == est && same_level(e.noise_level, l))
                .map(|e| (e.efficiency, e.se));
            match v {
                Some((v, se)) => {
                    w!(out, "<td class=\"num\">{}</td>", with_error(v, se));
                }
                None => {
                    w!(out, "<td class=\"num\">{MISSING}</td>");
                }
            }
        }
        out.push_str("</tr>\n");
    }
    out.push_str("</tbody>\n</table></div>\n</div>\n");
}

/// `v` to three significant digits, with `± se` (two significant digits)
/// when the standard error is a finite number.
fn with_error(v: f64, se: Option<f64>) -> String {
    match se.filter(|se| se.is_finite()) {
        Some(se) => format!("{} ± {}", sig(v, 3), sig(se, 2)),
        None => sig(v, 3),
    }
}

/// The time and FRF routes side by side: one row per noise level and
/// matrix, median and RMS relative error and efficiency of each route, and
/// the ratio of their mean square errors.
fn routes(out: &mut String, acc: &Accuracy) {
    if acc.routes.is_empty() {
        return;
    }
    out.push_str("<div class=\"routes\">\n<h4>Time and FRF routes</h4>\n<p class=\"lede\">Both routes identify the same simulated campaigns: the time route from the records (OKID, ERA/DC, MKR), the FRF route from FRFs averaged across the hits (pLSCF, LSFD, MKR). Relative Frobenius errors over the trials in which each route identified (± the Monte Carlo standard error); efficiency is the Cramér–Rao bound over the RMS error; the last column is the FRF route's mean square error over the time route's (above 1: the FRF route is worse). The Rayleigh damping has two parameters, fewer than the bound's parametrization, so its efficiency can exceed 1.</p>\n");
    out.push_str("<div class=\"table-wrap\"><table class=\"routes\">\n<thead><tr><th scope=\"col\">Noise</th><th scope=\"col\">Quantity</th>");
    for route in ["time", "FRF"] {
        for col in ["trials", "median", "RMS", "efficiency"] {
            w!(out, "<th scope=\"col\" class=\"num\">{route} {col}</th>");
        }
    }
    out.push_str("<th scope=\"col\" class=\"num\">MSE FRF / time</th></tr></thead>\n<tbody>\n");
    let cell_se = |out: &mut String, v: f64, se: Option<f64>| {
        if v.is_finite() {
            w!(out, "<td class=\"num\">{}</td>", with_error(v, se));
        } else {
            w!(out, "<td class=\"num\">{MISSING}</td>");
        }
    };
    let cell = |out: &mut String, v: f64| cell_se(out, v, None);
    for r in &acc.routes {
        w!(
            out,
            "<tr data-noise=\"{}\"><th scope=\"row\">{}</th><th scope=\"row\">{}</th>",
            r.noise_level,
            escape(&level_label(r.noise_level)),
            escape(&r.quantity)
        );
        for e in [&r.time, &r.frf] {
            w!(out, "<td class=\"num\">{}</td>", e.trials);
            cell_se(out, e.median, e.median_se);
            cell(out, e.rms);
            cell_se(out, e.efficiency, e.efficiency_se);
        }
        cell(out, (r.frf.rms / r.time.rms).powi(2));
        out.push_str("</tr>\n");
    }
    out.push_str("</tbody>\n</table></div>\n</div>\n");
}
