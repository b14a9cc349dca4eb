//! `frameid report` on sweep output, checked by parsing the HTML.

mod common;

use common::*;
use scraper::{Html, Selector};

fn select<'a>(doc: &'a Html, css: &str) -> Vec<scraper::ElementRef<'a>> {
    doc.select(&Selector::parse(css).unwrap()).collect()
}

#[test]
fn report_of_a_sweep_has_every_section_and_is_drawn_from_the_data() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("case1"), dir.path().join("frame3"));
    ok(&[
        "sweep",
        s(&repo("scenarios/paper-case1.toml")),
        "--out",
        s(&a),
        "--trials",
        "2",
        "--noise",
        "0,0.01,0.02,0.05",
    ]);
    ok(&[
        "sweep",
        s(&repo("scenarios/frame-three-storey.toml")),
        "--out",
        s(&b),
        "--trials",
        "2",
        "--noise",
        "0.01,0.05",
    ]);
    let html_path = dir.path().join("r.html");
    let out = ok(&["report", s(&a), s(&b), "--out", s(&html_path)]);
    assert!(out.contains("report:"), "{out}");
    let text = std::fs::read_to_string(&html_path).unwrap();
    // Self-contained: no external reference of any kind.
    for needle in [
        "http:",
        "https:",
        "src=\"//",
        "href=\"//",
        "<script",
        "@import",
        "url(",
    ] {
        assert!(!text.contains(needle), "found {needle}");
    }
    let doc = Html::parse_document(&text);
    let studies = select(&doc, "article.study");
    assert_eq!(studies.len(), 2);
    for (i, noise_levels, floors) in [(1, 4, 2), (2, 2, 3)] {
        let id = format!("#study-{i}");
        for section in ["setup", "representative", "comparison", "accuracy"] {
            assert_eq!(
                select(&doc, &format!("{id} section.{section}")).len(),
                1,
                "study {i} lacks {section}"
            );
        }
        // The paper's figures: force (Fig. 2), one acceleration per floor
        // (Fig. 3), Hankel singular values (Fig. 4), mode shapes (Fig. 5),
        // and the stabilization diagram and FRFs.
        assert_eq!(
            select(&doc, &format!("{id} svg[data-chart=force]")).len(),
            1
        );
        assert_eq!(
            select(&doc, &format!("{id} svg[data-chart=acceleration]")).len(),
            floors
        );
        assert_eq!(
            select(&doc, &format!("{id} svg[data-chart=hankel]")).len(),
            1
        );
        assert_eq!(
            select(&doc, &format!("{id} svg[data-chart=stabilization]")).len(),
            1
        );
        assert_eq!(
            select(&doc, &format!("{id} svg[data-chart=mode-magnitude]")).len(),
            floors
        );
        assert_eq!(
            select(&doc, &format!("{id} svg[data-chart=frf-magnitude]")).len(),
            floors
        );
        assert_eq!(
            select(&doc, &format!("{id} svg[data-chart=damping-comparison]")).len(),
            1
        );
        // The refined (maximum-likelihood) estimates have their own charts,
        // and the refined damping joins MKR and Rayleigh in the comparison.
        for key in [
            "mass_refined_err",
            "stiffness_refined_err",
            "f1_refined_err",
            "xi1_refined_err",
        ] {
            assert_eq!(
                select(&doc, &format!("{id} figure[data-quantity={key}]")).len(),
                1,
                "{key}"
            );
        }
        let refined = select(
            &doc,
            &format!(
                "{id} svg[data-chart=damping-comparison] g.series[data-series=refined-median][data-role=markers]"
            ),
        );
        assert_eq!(refined.len(), 1);
        // Every accuracy chart's median has one point per noise level.
        let medians = select(
            &doc,
            &format!(
                "{id} svg[data-chart=quantity] g.series[data-series=median][data-role=markers]"
            ),
        );
        assert!(medians.len() >= 3 * floors + 2, "one chart per quantity");
        for m in medians {
            assert_eq!(
                m.value().attr("data-points"),
                Some(noise_levels.to_string().as_str())
            );
        }
        // The time history is drawn from all 2048 samples of the record.
        let force = select(
            &doc,
            &format!("{id} svg[data-chart=force] g.series[data-role=line]"),
        );
        assert_eq!(force[0].value().attr("data-points"), Some("2048"));
        // Tables compare truth and identified f, xi, M, K and both damping
        // matrices, with error bars from the hits (leave-one-out), then the
        // refined f, xi, M, K and damping with their standard errors.
        let tables = select(&doc, &format!("{id} table.comparison"));
        assert_eq!(tables.len(), 6 + 5);
        let stds = select(&doc, &format!("{id} table.comparison td[data-std]"));
        assert!(
            !stds.is_empty()
                && stds
                    .iter()
                    .all(|td| td.value().attr("data-std") != Some("none"))
        );
        // One quality row per hit of the representative campaign.
        let hits = select(&doc, &format!("{id} table.hit-quality tbody tr"));
        assert_eq!(hits.len(), 10);
    }
    // The Cramér–Rao bound is drawn on the accuracy charts (at the noise
    // levels above zero), and the efficiency table lists the estimators.
    let bounds = select(
        &doc,
        "#study-1 svg[data-chart=quantity] g.series[data-series=bound]",
    );
    assert!(!bounds.is_empty(), "bound lines drawn");
    for b in &bounds {
        assert_eq!(
            b.value().attr("data-points"),
            Some("3"),
            "bound at the 3 non-zero noise levels"
        );
    }
    let eff = select(&doc, "#study-1 table.efficiency");
    assert_eq!(eff.len(), 1);
    let text = eff[0].text().collect::<String>();
    for estimator in ["MKR", "Rayleigh", "refined (ML)", "ERA/DC"] {
        assert!(
            text.contains(estimator),
            "efficiency table lacks {estimator}"
        );
    }
    for svg in select(&doc, "svg.chart") {
        assert!(
            svg.select(&Selector::parse("title").unwrap())
                .next()
                .is_some(),
            "every chart has a title"
        );
    }
}

#[test]
fn default_study_writes_the_report_and_prints_a_summary() {
    let dir = tempfile::tempdir().unwrap();
    let out = ok(&["study", "--out", s(dir.path()), "--trials", "1"]);
    assert!(
        out.contains("paper-case1")
            && out.contains("paper-case2")
            && out.contains("frame-added-mass"),
        "{out}"
    );
    assert!(out.contains("report:"), "{out}");
    let html = std::fs::read_to_string(dir.path().join("report.html")).unwrap();
    let doc = Html::parse_document(&html);
    assert_eq!(select(&doc, "article.study").len(), 3);
    for name in ["paper-case1", "paper-case2", "frame-added-mass"] {
        assert!(dir.path().join(name).join("summary.json").exists());
        assert!(dir.path().join(name).join("trials.csv").exists());
    }
}

#[test]
fn report_refuses_a_directory_without_a_summary() {
    let dir = tempfile::tempdir().unwrap();
    let html = dir.path().join("r.html");
    let (code, _, err) = run(&["report", s(dir.path()), "--out", s(&html)]);
    assert_eq!(code, 2);
    assert!(err.contains("summary.json: cannot read"), "{err}");
    assert!(!html.exists());
}
