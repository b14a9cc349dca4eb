//! The rendered document, parsed with a real HTML parser: sections, charts,
//! titles, axis labels, legends, and no external reference.

mod common;

use std::collections::{BTreeMap, BTreeSet};

use common::{child_elements, parse, sel, text};
use scraper::{ElementRef, Html};

fn rendered() -> (reports::Report, String, Html) {
    let report = common::report();
    let html = reports::render(&report).expect("the synthetic report renders");
    let doc = parse(&html);
    (report, html, doc)
}

#[test]
fn document_is_valid_html5_with_every_section() {
    let (report, _, doc) = rendered();
    assert!(doc.errors.is_empty(), "HTML parse errors: {:?}", doc.errors);
    assert_eq!(
        doc.select(&sel("head > title"))
            .map(text)
            .collect::<Vec<_>>(),
        vec![report.title.clone()]
    );
    assert_eq!(
        doc.select(&sel("h1")).map(text).next(),
        Some(report.title.clone())
    );

    let studies: Vec<ElementRef> = doc.select(&sel("article.study")).collect();
    assert_eq!(studies.len(), report.studies.len());
    for (i, (article, study)) in studies.iter().zip(&report.studies).enumerate() {
        let sid = format!("study-{}", i + 1);
        assert_eq!(article.value().attr("id"), Some(sid.as_str()));
        assert_eq!(
            article.value().attr("data-study"),
            Some(study.name.as_str())
        );
        for class in ["setup", "representative", "comparison", "accuracy"] {
            let found: Vec<_> = article.select(&sel(&format!("section.{class}"))).collect();
            assert_eq!(found.len(), 1, "{sid}: one section.{class}");
            assert_eq!(
                found[0].value().attr("id"),
                Some(format!("{sid}-{class}").as_str())
            );
            assert!(
                found[0].select(&sel("h3")).next().is_some(),
                "{sid}: section.{class} has a heading"
            );
        }

        // Set-up: every row, the version, the seed and the command.
        let setup = article
            .select(&sel("table.setup"))
            .next()
            .expect("setup table");
        let rows: Vec<(String, String)> = setup
            .select(&sel("tr"))
            .map(|tr| {
                (
                    tr.select(&sel("th")).map(text).collect(),
                    tr.select(&sel("td")).map(text).collect(),
                )
            })
            .collect();
        for row in &study.setup {
            assert!(
                rows.contains(&(row.label.clone(), row.value.clone())),
                "{sid}: setup row {:?}",
                row.label
            );
        }
        assert!(rows.contains(&("Seed".into(), study.seed.to_string())));
        assert!(rows.contains(&("frameid version".into(), report.frameid_version.clone())));
        assert!(rows.contains(&("Command".into(), report.command.clone())));

        // The representative campaign's figures.
        let rep = study
            .representative
            .as_ref()
            .expect("synthetic studies have one");
        let count = |kind: &str| {
            article
                .select(&sel(&format!(
                    "section.representative figure.chart[data-chart=\"{kind}\"]"
                )))
                .count()
        };
        assert_eq!(count("force"), 1);
        assert_eq!(count("acceleration"), rep.accelerations.len());
        assert_eq!(count("hankel"), 1);
        assert_eq!(count("stabilization"), 1);
        assert_eq!(count("mode-magnitude"), rep.modes.len());
        assert_eq!(count("mode-phase"), rep.modes.len());
        assert_eq!(count("frf-magnitude"), rep.frf.len());
        assert_eq!(count("frf-phase"), rep.frf.len());
        assert_eq!(
            article
                .select(&sel("section.comparison table.comparison"))
                .count(),
            rep.tables.len()
        );

        // Accuracy: one chart per quantity and panel, except the two damping
        // estimates, which share one chart per panel.
        let k = study.accuracy.panels.len();
        let keys: BTreeSet<&str> = study
            .accuracy
            .panels
            .iter()
            .flat_map(|p| p.quantities.iter().map(|q| q.key.as_str()))
            .collect();
        let acc = |s: &str| {
            article
                .select(&sel(&format!("section.accuracy {s}")))
                .count()
        };
        assert_eq!(
            acc("figure.chart[data-chart=\"quantity\"]"),
            (keys.len() - 2) * k
        );
        assert_eq!(acc("figure.chart[data-chart=\"damping-comparison\"]"), k);
        assert_eq!(acc("figure.chart[data-chart=\"failure-rate\"]"), k);
        assert_eq!(acc("table.failures"), k);
        assert_eq!(
            acc("table.efficiency"),
            usize::from(!study.accuracy.efficiency.is_empty())
        );
    }
}

#[test]
fn every_chart_has_a_title_axis_labels_and_a_legend_when_it_has_several_series() {
    let (_, _, doc) = rendered();
    let figures: Vec<ElementRef> = doc.select(&sel("figure.chart")).collect();
    let svgs: Vec<ElementRef> = doc.select(&sel("svg")).collect();
    assert!(svgs.len() > 50, "{} charts", svgs.len());
    assert_eq!(
        figures.len(),
        svgs.len(),
        "one svg per figure, none elsewhere"
    );
    for fig in figures {
        let id = fig.value().attr("id").unwrap_or("?");
        let svg = fig.select(&sel("svg.chart")).next().expect("svg in figure");
        assert_eq!(
            svg.value().attr("data-chart"),
            fig.value().attr("data-chart")
        );
        let title = svg
            .select(&sel("title"))
            .map(text)
            .next()
            .unwrap_or_default();
        assert!(!title.is_empty(), "{id}: <title>");
        let drawn_title: String = svg.select(&sel("g.chart-title text")).map(text).collect();
        assert_eq!(drawn_title, title, "{id}: drawn title");
        for axis in ["x", "y"] {
            let label: String = svg
                .select(&sel(&format!("g.axis-label[data-axis=\"{axis}\"] text")))
                .map(text)
                .collect();
            assert!(!label.is_empty(), "{id}: {axis} axis label");
        }
        assert!(
            svg.select(&sel("g.axes text")).count() >= 2,
            "{id}: tick labels"
        );

        let series: BTreeSet<&str> = svg
            .select(&sel("g.series"))
            .filter(|g| g.value().attr("data-role") != Some("rule"))
            .filter_map(|g| g.value().attr("data-series"))
            .collect();
        let legend: BTreeSet<&str> = svg
            .select(&sel("g.legend g.legend-entry"))
            .filter_map(|g| g.value().attr("data-series"))
            .collect();
        if series.len() > 1 {
            assert_eq!(legend, series, "{id}: one legend entry per series");
            for entry in svg.select(&sel("g.legend g.legend-entry")) {
                assert!(!text(entry).is_empty(), "{id}: legend entry text");
            }
        } else {
            assert!(legend.is_empty(), "{id}: no legend for a single series");
        }
    }
}

#[test]
fn axis_labels_carry_units() {
    let (_, _, doc) = rendered();
    let label = |chart: &str, axis: &str| -> BTreeSet<String> {
        doc.select(&sel(&format!(
            "svg[data-chart=\"{chart}\"] g.axis-label[data-axis=\"{axis}\"] text"
        )))
        .map(text)
        .collect()
    };
    let one = |s: &str| BTreeSet::from([s.to_string()]);
    assert_eq!(label("force", "x"), one("Time [s]"));
    assert_eq!(label("force", "y"), one("Force [N]"));
    assert_eq!(label("acceleration", "y"), one("Acceleration [m/s²]"));
    assert_eq!(label("stabilization", "x"), one("Frequency [Hz]"));
    assert_eq!(label("stabilization", "y"), one("Model order"));
    assert_eq!(label("frf-magnitude", "y"), one("|H| [dB re 1 (m/s²)/N]"));
    assert_eq!(label("frf-phase", "y"), one("Phase [deg]"));
    assert_eq!(label("mode-phase", "y"), one("Phase [deg]"));
    assert_eq!(label("failure-rate", "y"), one("Failure rate [%]"));
    for chart in ["quantity", "damping-comparison", "failure-rate"] {
        for l in label(chart, "x") {
            assert!(l.starts_with("Noise level [%]"), "{chart}: {l}");
        }
    }
}

#[test]
fn nothing_is_fetched_and_nothing_runs() {
    let (_, html, doc) = rendered();
    for tag in [
        "script",
        "link",
        "img",
        "iframe",
        "object",
        "embed",
        "base",
        "image",
        "use",
        "audio",
        "video",
        "source",
        "foreignObject",
    ] {
        assert_eq!(doc.select(&sel(tag)).count(), 0, "no <{tag}>");
    }
    let mut checked = 0;
    for el in doc
        .root_element()
        .descendants()
        .filter_map(ElementRef::wrap)
    {
        for (name, value) in el.value().attrs() {
            let name = name.to_ascii_lowercase();
            if name == "href"
                || name == "src"
                || name.ends_with(":href")
                || name == "action"
                || name == "srcset"
            {
                checked += 1;
                assert!(
                    value.starts_with('#'),
                    "<{}> {name}={value:?} is not a fragment",
                    el.value().name()
                );
            }
            assert!(!name.starts_with("on"), "event handler attribute {name}");
            assert!(
                !value.contains("url("),
                "{name}={value:?} references something"
            );
            if name == "style" {
                assert!(!value.contains("//"), "style {value:?}");
            }
        }
        assert!(
            el.value().attr("xmlns").is_none(),
            "namespace declarations are stripped"
        );
    }
    assert!(
        checked > 0,
        "the table of contents links are local fragments"
    );
    // The raw text: no protocol anywhere (the data of this report has none),
    // no CSS import, no protocol-relative reference.
    for needle in [
        "http:",
        "https:",
        "@import",
        "url(",
        "src=\"//",
        "href=\"//",
        "javascript:",
    ] {
        assert!(!html.contains(needle), "document contains {needle:?}");
    }
    // Every local link points at an element of the document.
    let ids: BTreeSet<&str> = doc
        .root_element()
        .descendants()
        .filter_map(ElementRef::wrap)
        .filter_map(|e| e.value().attr("id"))
        .collect();
    for a in doc.select(&sel("a[href]")) {
        let target = &a.value().attr("href").unwrap_or("#")[1..];
        assert!(ids.contains(target), "link to missing #{target}");
    }
}

#[test]
fn ids_are_unique() {
    let (_, _, doc) = rendered();
    let mut seen = BTreeMap::new();
    for el in doc
        .root_element()
        .descendants()
        .filter_map(ElementRef::wrap)
    {
        if let Some(id) = el.value().attr("id") {
            *seen.entry(id.to_string()).or_insert(0) += 1;
        }
    }
    let dups: Vec<_> = seen.iter().filter(|(_, n)| **n > 1).collect();
    assert!(dups.is_empty(), "duplicate ids: {dups:?}");
}

#[test]
fn second_axis_panels_sit_side_by_side_on_the_same_axes() {
    let (report, _, doc) = rendered();
    let (i, study) = report
        .studies
        .iter()
        .enumerate()
        .find(|(_, s)| s.accuracy.panels.len() > 1)
        .expect("a study with a second axis");
    let k = study.accuracy.panels.len();
    let article = doc
        .select(&sel(&format!("article#study-{}", i + 1)))
        .next()
        .unwrap();
    let rows: Vec<ElementRef> = article
        .select(&sel("section.accuracy .figure-row.panels"))
        .collect();
    assert!(!rows.is_empty());
    let ticks = |svg: ElementRef<'_>, anchor: &str| -> Vec<String> {
        svg.select(&sel(&format!("g.axes text[text-anchor=\"{anchor}\"]")))
            .map(text)
            .collect()
    };
    for row in rows {
        let figs: Vec<ElementRef> = child_elements(row)
            .into_iter()
            .filter(|e| e.value().name() == "figure" || e.value().name() == "div")
            .collect();
        assert_eq!(figs.len(), k, "one cell per panel");
        let panels: Vec<&str> = figs
            .iter()
            .filter_map(|f| f.value().attr("data-panel"))
            .collect();
        if panels.len() < 2 {
            continue;
        }
        let expected: Vec<String> = (1..=k).map(|p| p.to_string()).collect();
        assert_eq!(panels, expected);
        let svgs: Vec<ElementRef> = figs
            .iter()
            .map(|f| f.select(&sel("svg")).next().unwrap())
            .collect();
        for svg in &svgs[1..] {
            // Same y ticks (right-anchored labels) and same x ticks (centred).
            assert_eq!(ticks(*svg, "end"), ticks(svgs[0], "end"));
            assert_eq!(ticks(*svg, "middle"), ticks(svgs[0], "middle"));
        }
        // Each panel's title names its value of the second axis.
        for (svg, p) in svgs.iter().zip(&study.accuracy.panels) {
            let title: String = svg.select(&sel("title")).map(text).collect();
            let value = p.axis_value.as_deref().unwrap();
            assert!(title.contains(value), "{title:?} names {value:?}");
        }
    }
}

#[test]
fn rendering_is_deterministic() {
    let report = common::report();
    assert_eq!(
        reports::render(&report).unwrap(),
        reports::render(&report).unwrap()
    );
}

#[test]
fn the_default_report_is_small_and_fast() {
    let report = common::report();
    let start = std::time::Instant::now();
    let html = reports::render(&report).unwrap();
    let elapsed = start.elapsed();
    eprintln!(
        "3 studies, {} kB, rendered in {:.1} ms",
        html.len() / 1024,
        elapsed.as_secs_f64() * 1e3
    );
    assert!(html.len() > 100 * 1024, "{} bytes", html.len());
    assert!(html.len() < 3 * 1024 * 1024, "{} bytes", html.len());
    assert!(elapsed.as_secs_f64() < 2.0, "{elapsed:?}");
}
